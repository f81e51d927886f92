#include "maps/rl/actor_critic.h"

#include <cmath>

#include "autograd/gradcheck.h"
#include "envs/expert_policy.h"
#include "maps/rl/ppo.h"
#include "maps/rl/upright.h"
#include "rl_test_util.h"

namespace rltest {
namespace {

namespace ag = maps::ag;
namespace rl = maps::rl;
using ag::Dtype;
using ag::Tensor;

TEST(GaussianLogProb, MatchesClosedForm) {
  ag::Generator gen(3);
  const Tensor mean = ag::randn({5, 3}, gen, Dtype::Float64);
  const Tensor log_std = ag::randn({3}, gen, Dtype::Float64) * 0.5;
  const Tensor actions = ag::randn({5, 3}, gen, Dtype::Float64);
  const std::vector<double> lp = rl::gaussian_log_prob(mean, log_std, actions).to_vector();
  ASSERT_EQ(lp.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    double expected = 0.0;
    for (int d = 0; d < 3; ++d) {
      const double s = std::exp(log_std.at(d));
      const double z = (actions.at(i * 3 + d) - mean.at(i * 3 + d)) / s;
      expected += -0.5 * z * z - std::log(s) - 0.5 * std::log(2.0 * M_PI);
    }
    EXPECT_NEAR(lp[i], expected, 1e-12);
  }
  const double entropy = rl::gaussian_entropy(log_std).item();
  double expected_entropy = 0.0;
  for (int d = 0; d < 3; ++d) expected_entropy += 0.5 * std::log(2.0 * M_PI * M_E) + log_std.at(d);
  EXPECT_NEAR(entropy, expected_entropy, 1e-12);
}

TEST(GaussianLogProb, PassesGradcheck) {
  ag::Generator gen(4);
  Tensor mean = ag::randn({4, 2}, gen, Dtype::Float64);
  Tensor log_std = ag::randn({2}, gen, Dtype::Float64) * 0.3;
  Tensor actions = ag::randn({4, 2}, gen, Dtype::Float64);
  mean.requires_grad_();
  log_std.requires_grad_();
  actions.requires_grad_();
  const auto r = ag::gradcheck("gaussian_log_prob",
                               [](const std::vector<Tensor>& in) { return rl::gaussian_log_prob(in[0], in[1], in[2]); },
                               {mean, log_std, actions});
  EXPECT_TRUE(r.ok) << r.message;
}

// ratios 1.5, 0.5, 1.1, 0.7 with advantages 1, 1, -1, -1 and clip 0.2:
// min(r A, clip(r) A) = 1.2, 0.5, -1.1, -0.8 -> loss = -(-0.2 / 4) = 0.05; only the unclipped terms have a
// gradient: d/dlogp = -(1/4) r A = 0, -0.125, +0.275, 0.
TEST(PpoClipLoss, HandExample) {
  Tensor log_prob = ag::from_vector({std::log(1.5), std::log(0.5), std::log(1.1), std::log(0.7)}, {4}, Dtype::Float64);
  log_prob.requires_grad_();
  const Tensor old_log_prob = ag::zeros({4}, Dtype::Float64);
  const Tensor advantages = ag::from_vector({1.0, 1.0, -1.0, -1.0}, {4}, Dtype::Float64);
  const Tensor loss = rl::ppo_clip_loss(log_prob, old_log_prob, advantages, 0.2);
  EXPECT_NEAR(loss.item(), 0.05, 1e-12);
  loss.backward();
  const std::vector<double> g = log_prob.grad().to_vector();
  EXPECT_NEAR(g[0], 0.0, 1e-12);
  EXPECT_NEAR(g[1], -0.125, 1e-12);
  EXPECT_NEAR(g[2], 0.275, 1e-12);
  EXPECT_NEAR(g[3], 0.0, 1e-12);
}

TEST(ActorCritic, OrthogonalInitAndShapes) {
  ag::Generator gen(5);
  rl::ActorCritic model({.observation_size = 17, .action_size = 6}, gen);
  const auto w0 = ag::to_eigen_double(model.parameter("policy.layers.0.weight"));  // [64, 17]
  EXPECT_LT((w0.transpose() * w0 - 2.0 * Eigen::MatrixXd::Identity(17, 17)).cwiseAbs().maxCoeff(), 1e-4);
  const auto w2 = ag::to_eigen_double(model.parameter("policy.layers.2.weight"));  // [6, 64]
  EXPECT_LT((w2 * w2.transpose() - 1e-4 * Eigen::MatrixXd::Identity(6, 6)).cwiseAbs().maxCoeff(), 1e-8);
  const auto v2 = ag::to_eigen_double(model.parameter("value.layers.2.weight"));  // [1, 64]
  EXPECT_NEAR((v2 * v2.transpose())(0, 0), 1.0, 1e-5);
  for (const auto& p : model.named_parameters()) {
    if (p.name.find("bias") != std::string::npos || p.name == "log_std") {
      EXPECT_EQ(ag::to_eigen_double(p.tensor).cwiseAbs().maxCoeff(), 0.0) << p.name;
    }
  }
  const Tensor obs = ag::randn({3, 17}, gen);
  EXPECT_EQ(model.mean_action(obs).shape(), (ag::Shape{3, 6}));
  EXPECT_EQ(model.value(obs).shape(), (ag::Shape{3}));
}

TEST(ExportExpert, MeanActionMatchesTheActor) {
  ag::Generator gen(6);
  rl::ActorCritic model({.observation_size = 5, .action_size = 3, .hidden = {16, 8}}, gen);
  // Move the weights off their init so every layer matters.
  for (auto& p : model.parameters()) {
    ag::NoGradGuard no_grad;
    p.copy_(p + ag::randn(p.shape(), gen) * 0.3);
  }
  rl::RunningMeanStd stats(5);
  std::mt19937_64 rng(8);
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::MatrixXd data(50, 5);
  for (int i = 0; i < 50; ++i)
    for (int j = 0; j < 5; ++j) data(i, j) = 3.0 * j + (j + 1) * n(rng);
  stats.update_batch(data);
  const maps::envs::ExpertPolicy expert = rl::export_expert(model, stats, "toy/point", R"({"seed": 6})");
  EXPECT_NO_THROW(expert.validate());
  EXPECT_EQ(expert.weights.size(), 3u);
  EXPECT_EQ(expert.weights[0].rows(), 16);
  EXPECT_EQ(expert.weights[0].cols(), 5);
  for (int i = 0; i < 20; ++i) {
    Eigen::VectorXd obs(5);
    for (int j = 0; j < 5; ++j) obs(j) = 3.0 * j + 2.0 * (j + 1) * n(rng);
    const Eigen::VectorXd expected = [&] {
      ag::NoGradGuard no_grad;
      const Eigen::VectorXd z = stats.normalize(obs);
      Tensor x = ag::empty({1, 5});
      x.matrix<float>() = z.transpose().cast<float>();
      const auto v = model.mean_action(x).to_vector();
      return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(v.data(), 3));
    }();
    EXPECT_LT((expert.mean_action(obs) - expected).cwiseAbs().maxCoeff(), 1e-5) << "observation " << i;
  }
}

TEST(Upright, FlippedFraction) {
  EXPECT_EQ(rl::flipped_fraction({}), 0.0);
  const std::vector<double> pitches = {0.0, 0.1, 3.0, -3.0};
  EXPECT_DOUBLE_EQ(rl::flipped_fraction(pitches), 0.5);
  EXPECT_TRUE(rl::ran_flipped(pitches, 0.4));
  EXPECT_FALSE(rl::ran_flipped(pitches, 0.5));
  EXPECT_FALSE(rl::ran_flipped({0.2, -0.5, 1.2, 7.0}));  // 7 rad is 0.72 past a full turn: upright
}

}  // namespace
}  // namespace rltest
