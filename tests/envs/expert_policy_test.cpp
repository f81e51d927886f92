#include "envs/expert_policy.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>

namespace maps::envs {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

// A 17-64-64-6 policy with awkward doubles (full 53-bit mantissas, tiny and huge exponents).
ExpertPolicy make_policy() {
  std::mt19937_64 rng(1234);
  std::normal_distribution<double> normal(0.0, 1.0);
  const auto random_matrix = [&](int rows, int cols) {
    Eigen::MatrixXd m(rows, cols);
    for (int i = 0; i < m.size(); ++i) m.data()[i] = normal(rng) / 3.0;
    return m;
  };
  ExpertPolicy p;
  p.task = "gravity/0.5";
  p.obs_mean = random_matrix(17, 1);
  p.obs_var = random_matrix(17, 1).cwiseAbs();
  p.obs_mean[0] = 1e-300;
  p.obs_var[1] = 1.7976931348623157e308;
  p.obs_var[2] = 0.0;
  const int sizes[4] = {17, 64, 64, 6};
  for (int i = 0; i < 3; ++i) {
    p.weights.push_back(random_matrix(sizes[i + 1], sizes[i]));
    p.biases.push_back(random_matrix(sizes[i + 1], 1));
  }
  p.log_std = random_matrix(6, 1);
  p.metadata_json = R"({"seed":7,"steps":5000000})";
  return p;
}

class ExpertPolicyFile : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("maps_expert_policy_test_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }
  static std::string read(const std::string& file) {
    std::ifstream in(file);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }
  static void write(const std::string& file, const std::string& text) { std::ofstream(file) << text; }

  fs::path dir_;
};

TEST(ExpertPolicy, SizesAndMeanAction) {
  const ExpertPolicy p = make_policy();
  EXPECT_EQ(p.observation_size(), 17);
  EXPECT_EQ(p.action_size(), 6);
  const Eigen::VectorXd obs = Eigen::VectorXd::LinSpaced(17, -1.0, 1.0);
  Eigen::VectorXd h = ((obs - p.obs_mean).array() / (p.obs_var.array() + 1e-8).sqrt()).cwiseMax(-10.0).cwiseMin(10.0);
  h = (p.weights[0] * h + p.biases[0]).array().tanh();
  h = (p.weights[1] * h + p.biases[1]).array().tanh();
  h = p.weights[2] * h + p.biases[2];
  EXPECT_TRUE(p.mean_action(obs).isApprox(h, 1e-12));
  // Normalised observations are clipped to [-obs_clip, obs_clip].
  EXPECT_LE(p.normalize(Eigen::VectorXd::Constant(17, 1e6)).maxCoeff(), 10.0);
}

TEST(ExpertPolicy, SampleActionIsMeanPlusScaledNoise) {
  const ExpertPolicy p = make_policy();
  const Eigen::VectorXd obs = Eigen::VectorXd::Zero(17);
  std::mt19937_64 a(5), b(5);
  EXPECT_EQ(p.sample_action(obs, a), p.sample_action(obs, b));
  std::mt19937_64 rng(6);
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(6);
  const int n = 4000;
  for (int i = 0; i < n; ++i)
    sum += (p.sample_action(obs, rng) - p.mean_action(obs)).cwiseQuotient(p.log_std.array().exp().matrix()).cwiseAbs2();
  EXPECT_TRUE(((sum / n).array() - 1.0).abs().maxCoeff() < 0.15);
}

TEST(ExpertPolicy, WrongObservationSizeNamesTask) {
  const ExpertPolicy p = make_policy();
  EXPECT_THAT([&] { p.mean_action(Eigen::VectorXd::Zero(16)); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("gravity/0.5")));
}

TEST(ExpertPolicy, ValidateNamesInconsistency) {
  ExpertPolicy p = make_policy();
  p.biases[1].resize(63);
  EXPECT_THAT([&] { p.validate(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("layer 1")));
  p = make_policy();
  p.log_std.resize(5);
  EXPECT_THAT([&] { p.validate(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("log_std")));
  p = make_policy();
  p.obs_var.resize(16);
  EXPECT_THAT([&] { p.validate(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("obs_var")));
  p = make_policy();
  p.weights[2].resize(6, 63);
  EXPECT_THAT([&] { p.validate(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("layer 2")));
  p = make_policy();
  p.weights[0](0, 0) = std::nan("");
  EXPECT_THAT([&] { p.validate(); }, ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("non-finite")));
}

TEST_F(ExpertPolicyFile, RoundTripIsExact) {
  const ExpertPolicy p = make_policy();
  p.save(path("expert.json"));
  const ExpertPolicy q = ExpertPolicy::load(path("expert.json"));
  EXPECT_EQ(q.task, p.task);
  EXPECT_EQ(q.obs_mean, p.obs_mean);
  EXPECT_EQ(q.obs_var, p.obs_var);
  EXPECT_EQ(q.obs_clip, p.obs_clip);
  EXPECT_EQ(q.obs_epsilon, p.obs_epsilon);
  ASSERT_EQ(q.weights.size(), p.weights.size());
  for (std::size_t i = 0; i < p.weights.size(); ++i) {
    EXPECT_EQ(q.weights[i], p.weights[i]) << i;
    EXPECT_EQ(q.biases[i], p.biases[i]) << i;
  }
  EXPECT_EQ(q.log_std, p.log_std);
  EXPECT_EQ(q.metadata_json, p.metadata_json);
  const Eigen::VectorXd obs = Eigen::VectorXd::LinSpaced(17, -2.0, 2.0);
  EXPECT_EQ(q.mean_action(obs), p.mean_action(obs));
  // Saving again gives the same bytes; no temporary file is left behind.
  q.save(path("again.json"));
  EXPECT_EQ(read(path("expert.json")), read(path("again.json")));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 2);
}

TEST_F(ExpertPolicyFile, MissingFileNamesIt) {
  EXPECT_THAT([&] { ExpertPolicy::load(path("absent.json")); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("absent.json")));
}

TEST_F(ExpertPolicyFile, TruncatedFileNamesIt) {
  make_policy().save(path("expert.json"));
  const std::string text = read(path("expert.json"));
  write(path("truncated.json"), text.substr(0, text.size() / 2));
  EXPECT_THAT([&] { ExpertPolicy::load(path("truncated.json")); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  ::testing::AllOf(HasSubstr("truncated.json"), HasSubstr("not valid JSON"))));
}

TEST_F(ExpertPolicyFile, MissingFieldNamesIt) {
  write(path("partial.json"), R"({"format": "maps.expert_policy", "version": 1, "task": "x"})");
  EXPECT_THAT(
      [&] { ExpertPolicy::load(path("partial.json")); },
      ::testing::ThrowsMessage<std::runtime_error>(::testing::AllOf(HasSubstr("partial.json"), HasSubstr("obs_mean"))));
}

TEST_F(ExpertPolicyFile, WrongFormatOrTypeIsAnError) {
  write(path("other.json"), R"({"format": "something.else", "version": 1})");
  EXPECT_THAT([&] { ExpertPolicy::load(path("other.json")); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("format")));
  make_policy().save(path("expert.json"));
  const nlohmann::json good = nlohmann::json::parse(read(path("expert.json")));
  auto refused_with = [&](const char* key, const nlohmann::json& value, const std::string& needle) {
    nlohmann::json bad = good;
    bad[key] = value;
    write(path("typed.json"), bad.dump());
    EXPECT_THAT(
        [&] { ExpertPolicy::load(path("typed.json")); },
        ::testing::ThrowsMessage<std::runtime_error>(::testing::AllOf(HasSubstr("typed.json"), HasSubstr(needle))))
        << key << " = " << value.dump();
  };
  refused_with("obs_clip", "ten", "obs_clip");
  refused_with("obs_clip", 0, "field obs_clip: expected a finite number in (0, 1000000], got 0");
  refused_with("obs_epsilon", -1, "field obs_epsilon");
  refused_with("obs_var", {1.0, -1.0}, "field obs_var[1]");
  // Read as an int, 2^32 + 1 was version 1.
  refused_with("version", 4294967297ULL, "unsupported version 4294967297");
  refused_with("ignored", 1, "unknown field 'ignored'");
  refused_with("metadata", 3, "field metadata: expected an object");
}

TEST_F(ExpertPolicyFile, InconsistentFileNamesFileAndProblem) {
  ExpertPolicy p = make_policy();
  p.save(path("expert.json"));
  std::string text = read(path("expert.json"));
  // Drop the last log_std entry: the file parses but no longer matches the network.
  const auto at = text.find("\"log_std\": [");
  ASSERT_NE(at, std::string::npos);
  const auto first_comma = text.find(',', at);
  const auto first_value = text.find('[', at) + 1;
  text.erase(first_value, first_comma + 1 - first_value);
  write(path("inconsistent.json"), text);
  EXPECT_THAT([&] { ExpertPolicy::load(path("inconsistent.json")); },
              ::testing::ThrowsMessage<std::runtime_error>(
                  ::testing::AllOf(HasSubstr("inconsistent.json"), HasSubstr("log_std"))));
}

TEST_F(ExpertPolicyFile, SaveRefusesInvalidPolicyAndKeepsOldFile) {
  ExpertPolicy p = make_policy();
  p.save(path("expert.json"));
  const std::string before = read(path("expert.json"));
  p.log_std.resize(2);
  EXPECT_THROW(p.save(path("expert.json")), std::invalid_argument);
  EXPECT_EQ(read(path("expert.json")), before);
  p = make_policy();
  p.metadata_json = "{not json";
  EXPECT_THAT([&] { p.save(path("expert.json")); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("metadata_json")));
}

}  // namespace
}  // namespace maps::envs
