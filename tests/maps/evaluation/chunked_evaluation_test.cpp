// The evaluator running policies that predict action chunks or read the previous state (issue 46, item 2): open loop
// queries a chunk every `execute` steps and takes its actions in order, the temporal ensemble queries every step and
// averages the chunks covering it, only the episodes that ask are queried, and the previous observation handed to the
// policy is the episode's own (the first state itself at t = 0). Checked on a toy env whose reward is the action, so
// each episode's return is the sum of the actions it took.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "maps/evaluation/evaluator.h"
#include "maps/evaluation/step_actions.h"
#include "tests/common/error_of.h"

namespace maps::core {
namespace {

using ::testing::HasSubstr;

// obs (t, episode seed, 0); reward = the action's first entry; episodes of 3 + seed % 5 steps.
class StepCountEnv : public envs::Env {
 public:
  explicit StepCountEnv(std::string task) { spec_ = envs::unit_box_spec(std::move(task), 0, 3, 2, 100); }
  const envs::EnvSpec& spec() const override { return spec_; }
  Eigen::VectorXd reset(std::uint64_t seed) override {
    seed_ = static_cast<double>(seed % 1000);
    t_ = 0;
    length_ = 3 + static_cast<int>(seed % 5);
    return obs();
  }
  envs::StepResult step(const Eigen::VectorXd& action) override {
    ++t_;
    envs::StepResult r;
    r.observation = obs();
    r.reward = action[0];
    r.terminated = t_ >= length_;
    return r;
  }
  int length() const { return length_; }

 private:
  Eigen::VectorXd obs() const { return Eigen::Vector3d(t_, seed_, 0.0); }
  envs::EnvSpec spec_;
  double seed_ = 0.0;
  int t_ = 0, length_ = 0;
};

// A chunk policy: the chunk asked for at step t0 has action j = (t0 / 10 + j / 1000, 0); it records every row it
// was asked for (t0, seed, previous t0).
class RecordingChunkPolicy : public Policy {
 public:
  explicit RecordingChunkPolicy(const chunking::ActionChunking& chunking)
      : Policy("RecordingChunkPolicy", {3, chunking.horizon * 2, 1}) {
    set_chunking(chunking, 2);
  }
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override {
    return act_with_history(observations, observations, tasks);
  }
  ag::Tensor act_with_history(const ag::Tensor& observations, const ag::Tensor& previous,
                              const std::vector<std::int64_t>& /*tasks*/) override {
    const ag::RowMatrixD obs = ag::to_eigen_double(observations), prev = ag::to_eigen_double(previous);
    ag::RowMatrixD chunks = ag::RowMatrixD::Zero(obs.rows(), shape().action_size);
    for (Eigen::Index i = 0; i < obs.rows(); ++i) {
      asked.push_back({obs(i, 0), obs(i, 1), prev(i, 0), prev(i, 1)});
      for (std::int64_t j = 0; j < chunking().horizon; ++j) chunks(i, 2 * j) = obs(i, 0) / 10.0 + j / 1000.0;
    }
    return ag::from_eigen(chunks).to(observations.dtype());
  }
  LossTerms loss(const Batch&) override { throw std::logic_error("not trainable"); }

  struct Asked {
    double t, seed, previous_t, previous_seed;
  };
  std::vector<Asked> asked;

 protected:
  std::shared_ptr<nn::Module> shallow_copy() const override { return std::make_shared<RecordingChunkPolicy>(*this); }
};

Standardizer identity(std::int64_t size) {
  Standardizer s;
  s.mean = Eigen::VectorXd::Zero(size);
  s.std = Eigen::VectorXd::Ones(size);
  return s;
}

EvaluationResult run(RecordingChunkPolicy& policy, int episodes, int envs_per_task) {
  EvalConfig config;
  config.episodes = episodes;
  config.first_seed = 0;
  config.threads = 1;
  config.dtype = ag::Dtype::Float64;
  config.max_envs_per_task = envs_per_task;
  return evaluate_with_envs([](const std::string& task) { return std::make_unique<StepCountEnv>(task); }, policy,
                            identity(3), {"toy/a"}, {}, config);
}

int length_of(int seed) { return 3 + seed % 5; }

chunking::ActionChunking open_loop(std::int64_t horizon, std::int64_t execute) {
  chunking::ActionChunking c;
  c.horizon = horizon;
  c.execution = "open_loop";
  c.execute = execute;
  return c;
}

TEST(ChunkedEvaluation, OpenLoopQueriesEveryExecuteStepsAndTakesTheChunksActionsInOrder) {
  const chunking::ActionChunking c = open_loop(4, 3);
  RecordingChunkPolicy policy(c);
  const EvaluationResult result = run(policy, 6, 4);
  std::size_t expected_queries = 0;
  for (int e = 0; e < 6; ++e) {
    double expected = 0.0;
    for (int t = 0; t < length_of(e); ++t) {
      const int asked_at = t - t % 3;
      expected += asked_at / 10.0 + (t - asked_at) / 1000.0;
    }
    expected_queries += static_cast<std::size_t>((length_of(e) + 2) / 3);
    EXPECT_NEAR(result.tasks[0].returns[static_cast<std::size_t>(e)], expected, 1e-12) << "episode " << e;
  }
  // Only the episodes whose chunk was spent were asked, each at steps 0, 3, 6, ...
  EXPECT_EQ(policy.asked.size(), expected_queries);
  for (const auto& a : policy.asked) EXPECT_EQ(static_cast<int>(a.t) % 3, 0) << "asked at step " << a.t;
}

TEST(ChunkedEvaluation, TheEnsembleQueriesEveryStepAndAveragesTheChunksCoveringIt) {
  chunking::ActionChunking c;
  c.horizon = 3;
  c.execution = "ensemble";
  c.ensemble_decay = 0.0;  // equal weights: the plain mean of the covering chunks' votes
  RecordingChunkPolicy policy(c);
  const EvaluationResult result = run(policy, 5, 2);
  std::size_t steps = 0;
  for (int e = 0; e < 5; ++e) {
    double expected = 0.0;
    for (int t = 0; t < length_of(e); ++t) {
      double sum = 0.0;
      int votes = 0;
      for (int t0 = std::max(0, t - 2); t0 <= t; ++t0, ++votes) sum += t0 / 10.0 + (t - t0) / 1000.0;
      expected += sum / votes;
    }
    steps += static_cast<std::size_t>(length_of(e));
    EXPECT_NEAR(result.tasks[0].returns[static_cast<std::size_t>(e)], expected, 1e-12) << "episode " << e;
  }
  EXPECT_EQ(policy.asked.size(), steps);
}

TEST(ChunkedEvaluation, ThePreviousObservationIsTheEpisodesOwnAndTheFirstStateAtTheStart) {
  chunking::ActionChunking c;
  c.horizon = 2;
  c.execution = "ensemble";
  c.previous_observation = true;
  RecordingChunkPolicy policy(c);
  run(policy, 7, 3);  // fewer envs than episodes: envs start new episodes mid-run
  ASSERT_FALSE(policy.asked.empty());
  for (const auto& a : policy.asked) {
    EXPECT_EQ(a.previous_seed, a.seed);
    EXPECT_EQ(a.previous_t, a.t == 0 ? 0.0 : a.t - 1.0) << "seed " << a.seed;
  }
}

TEST(ChunkedEvaluation, AChunkOfTheWrongWidthIsNamed) {
  chunking::ActionChunking c;
  c.horizon = 2;
  RecordingChunkPolicy policy(c);
  // A policy built for chunks of 2 but run by the evaluator as chunks of 3 (set_chunking refuses the sizes first).
  EXPECT_THAT(error_of([&] { policy.set_chunking(chunking::ActionChunking{3}, 2); }),
              HasSubstr("need an output of 6, the policy was built for 4"));
  chunking::ActionChunking bad;
  bad.horizon = 2;
  bad.execution = "open_loop";
  bad.execute = 3;
  EXPECT_THAT(error_of([&] { chunking::check_action_chunking(bad, "chunking"); }),
              HasSubstr("config chunking.execute: expected 1 to the horizon (2)"));
  bad.execute = 1;
  bad.execution = "closed";
  EXPECT_THAT(error_of([&] { chunking::check_action_chunking(bad, "chunking"); }),
              HasSubstr("config chunking.execution: expected \"ensemble\" or \"open_loop\""));
}

// The step that the evaluator and `maps render` share: only the rows whose executor asks are queried, in one call,
// and each row acts by its own executor.
TEST(ChunkedEvaluation, StepActionsQueriesOnlyTheAskingRowsAndActsByEachRowsExecutor) {
  const chunking::ActionChunking c = open_loop(2, 2);
  RecordingChunkPolicy policy(c);
  chunking::ChunkExecutor first(c, 2), second(c, 2);
  const ag::Tensor step0 = ag::from_eigen(ag::RowMatrixD{{0.0, 7.0, 0.0}, {10.0, 8.0, 0.0}});
  ag::RowMatrixD a = step_actions(policy, step0, step0, 0, {&first, &second}, "test");
  ASSERT_EQ(policy.asked.size(), 2u);
  EXPECT_DOUBLE_EQ(a(0, 0), 0.0);
  EXPECT_DOUBLE_EQ(a(1, 0), 1.0);
  // Next step: both executors still hold their chunk's second action; a third, new episode asks alone.
  chunking::ChunkExecutor third(c, 2);
  const ag::Tensor step1 = ag::from_eigen(ag::RowMatrixD{{1.0, 7.0, 0.0}, {11.0, 8.0, 0.0}, {20.0, 9.0, 0.0}});
  a = step_actions(policy, step1, step1, 0, {&first, &second, &third}, "test");
  ASSERT_EQ(policy.asked.size(), 3u);
  EXPECT_DOUBLE_EQ(policy.asked.back().seed, 9.0);
  EXPECT_DOUBLE_EQ(a(0, 0), 0.001);
  EXPECT_DOUBLE_EQ(a(1, 0), 1.001);
  EXPECT_DOUBLE_EQ(a(2, 0), 2.0);
  EXPECT_THAT(error_of([&] { step_actions(policy, step1, step1, 0, {&first}, "evaluate: task 'toy/a'"); }),
              HasSubstr("evaluate: task 'toy/a': 1 executors for 3 running episodes"));
  // A policy acting per step takes no executors.
  RecordingChunkPolicy per_step(chunking::ActionChunking{});
  EXPECT_THAT(error_of([&] {
                step_actions(per_step, step1, step1, 0, {&first, &second, &third}, "render: task 'x'");
              }),
              HasSubstr("render: task 'x': executors given for a policy acting per step"));
}

}  // namespace
}  // namespace maps::core
