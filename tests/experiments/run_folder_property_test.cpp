// Run folders damaged at random (issue 41, item 6): config.json (bytes and JSON structure) and best.ckpt's record
// (rewritten with a valid checksum), read by load_trained_run as `maps eval` and the Python module read them. An
// error must name the run folder (a changed config can show as a missing demo file or a model of another size) or,
// for the record, best.ckpt.
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "envs/demo_file.h"
#include "experiments/run/run_folder.h"
#include "io/config_schema.h"
#include "maps/training/checkpoint_record.h"
#include "maps/training/run_config_fields.h"
#include "nn/serialize.h"
#include "tests/common/mutations.h"
#include "tests/common/temp_folder.h"

namespace maps::experiments {
namespace {

using Json = nlohmann::json;

class RunFolderProperty : public TempFolderTest {
 protected:
  RunFolderProperty() : TempFolderTest("maps_run_folder_property_") {}

  // A run folder of an untrained MT-BC policy on a small demo file: config.json and best.ckpt, as maps train
  // writes them.
  void SetUp() override {
    TempFolderTest::SetUp();
    envs::DemoFile file;
    file.task_set = "gravity";
    file.task_names = {"gravity/0.5", "gravity/1.5"};
    std::mt19937_64 rng(3);
    std::normal_distribution<double> normal;
    for (int i = 0; i < 6; ++i) {
      envs::Demonstration d;
      d.task_index = i % 2;
      d.task = file.task_names[static_cast<std::size_t>(d.task_index)];
      d.seed = static_cast<std::uint64_t>(i);
      d.obs = Eigen::MatrixXd::NullaryExpr(8, 3, [&] { return normal(rng); });
      d.actions = Eigen::MatrixXd::NullaryExpr(8, 2, [&] { return normal(rng); });
      d.rewards = Eigen::VectorXd::Zero(8);
      d.dones.assign(8, 0);
      d.dones.back() = 1;
      d.final_obs = Eigen::VectorXd::Zero(3);
      d.end = envs::EpisodeEnd::kTruncated;
      file.demos.push_back(std::move(d));
    }
    file.train = {0, 1, 2, 3};
    file.valid = {4, 5};
    envs::write_demo_file(path("demos.h5"), file);
    config_ = core::to_json(core::parse_run_config(
        {{"method", "mt_bc"}, {"data", {{"file", path("demos.h5")}}}, {"baselines", {{"hidden", {8}}}}}));
    run_ = path("run");
    std::filesystem::create_directories(run_);
    write_json_file(run_ + "/config.json", config_);
    const core::RunConfig config = core::parse_run_config(config_);
    const core::DemoDataset data(envs::read_demo_file(config.data_file), config.data);
    const auto policy = core::make_policy(config, {3, 2, 2});
    core::PolicyRecord record;
    record.step = 10;
    record.standardizer = data.standardizer();
    record_ = core::to_json(record);
    tensors_ = policy->state_dict();
    nn::save_tensors(run_ + "/best.ckpt", tensors_, record_.dump());
    load_trained_run(run_);  // the undamaged folder loads
  }

  Json config_, record_;
  nn::NamedTensors tensors_;
  std::string run_;
};

// An accepted config: every key within its range (the schema's check, on the config as re-written) and the same
// config when read again.
bool config_holds(const core::RunConfig& config, std::string& why) {
  const Json written = core::to_json(config);
  for (const io::Field& field : core::run_config_schema()) {
    const Json::json_pointer at = io::key_pointer(field.key);
    if (!written.contains(at)) continue;  // another method's section
    try {
      io::check_value(field, written.at(at));
    } catch (const std::invalid_argument& e) {
      why = e.what();
      return false;
    }
  }
  if (core::to_json(core::parse_run_config(written)) != written) {
    why = "not a fixed point of parse and write";
    return false;
  }
  return true;
}

TEST_F(RunFolderProperty, ADamagedConfigIsRefusedNamingItOrReadWithEveryKeyInRange) {
  const std::string original = testing::read_bytes(run_ + "/config.json");
  TrainedRun loaded;
  auto load = [&](const std::string&) { loaded = load_trained_run(run_); };
  auto holds = [&](std::string& why) { return config_holds(loaded.config, why); };
  testing::check_mutants(
      "run folder config.json bytes", original, run_ + "/config.json", testing::property_cases(150),
      [&](std::mt19937_64& rng, std::string& how) { return testing::byte_mutant(original, rng, how); }, load, holds,
      run_);
  testing::check_mutants(
      "run folder config.json structure", original, run_ + "/config.json", testing::property_cases(300),
      [&](std::mt19937_64& rng, std::string& how) { return testing::json_mutant(config_, rng, how).dump(2); }, load,
      holds, run_);
}

TEST_F(RunFolderProperty, ADamagedCheckpointRecordIsRefusedNamingIt) {
  const std::string best = run_ + "/best.ckpt";
  TrainedRun loaded;
  testing::check_mutants(
      "run folder best.ckpt record", "", best, testing::property_cases(300),
      [&](std::mt19937_64& rng, std::string& how) {
        nn::save_tensors(best, tensors_, testing::json_mutant(record_, rng, how).dump());
        return testing::read_bytes(best);
      },
      [&](const std::string&) { loaded = load_trained_run(run_); },
      [&](std::string& why) {
        // Accepted: the standardizer is the data's (any other is refused), the step a non-negative integer.
        why = loaded.best.dump().substr(0, 200);
        return loaded.best.at("step").is_number_integer() && loaded.best.at("step").get<std::int64_t>() >= 0 &&
               loaded.best.at("standardizer") == record_.at("standardizer");
      },
      "best.ckpt");
}

// A run's inputs are clamped as its checkpoint records: a config.json that says otherwise is refused, naming both.
TEST_F(RunFolderProperty, AClampOtherThanTheCheckpointsIsRefused) {
  Json clamped = config_;
  clamped["data"]["observation_clip"] = 10.0;
  write_json_file(run_ + "/config.json", clamped);
  try {
    load_trained_run(run_);
    ADD_FAILURE() << "a config clamping inputs the checkpoint did not was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no bound"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("data.observation_clip +-10"), std::string::npos) << e.what();
  }
  core::PolicyRecord record = core::read_policy_record(record_.dump(), "best.ckpt", 3);
  record.standardizer.clip = 10.0;
  nn::save_tensors(run_ + "/best.ckpt", tensors_, core::to_json(record).dump());
  EXPECT_EQ(load_trained_run(run_).best.at("standardizer").at("clip"), 10.0);  // both say 10: loads
  // A run that starts from this one (init.run) must clamp its inputs as the reused layers saw them.
  Json started = config_;
  started["init"]["run"] = run_;
  started["data"]["observation_clip"] = 5.0;
  try {
    load_run_dataset(core::parse_run_config(started), path("next"));
    ADD_FAILURE() << "a run starting from one clamped otherwise was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("init.run: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("clamped to +-10; this run's data.observation_clip says +-5"),
              std::string::npos)
        << e.what();
  }
  started["data"]["observation_clip"] = 10.0;
  EXPECT_EQ(load_run_dataset(core::parse_run_config(started), path("next")).standardizer().clip, 10.0);
}

}  // namespace
}  // namespace maps::experiments
