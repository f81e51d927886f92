#include "envs/demo_collection.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <stdexcept>

#include "envs/half_cheetah.h"
#include "envs/source_folders.h"
#include "envs/task_sets.h"

namespace maps::envs {
namespace {

using ::testing::HasSubstr;

// One state x, x' = x + a, reward x'; horizon 10. Episodes from odd seeds end in the failure state, episodes from
// seeds that are multiples of 5 spend 3 of their 10 steps there but end outside it.
class FakeEnv : public Env {
 public:
  FakeEnv() {
    spec_.task = "fake/walker";
    spec_.task_index = 2;
    spec_.observation_size = 1;
    spec_.action_size = 1;
    spec_.action_low = Eigen::VectorXd::Constant(1, -1.0);
    spec_.action_high = Eigen::VectorXd::Constant(1, 1.0);
    spec_.horizon = 10;
  }
  const EnvSpec& spec() const override { return spec_; }
  Eigen::VectorXd reset(std::uint64_t seed) override {
    seed_ = seed;
    t_ = 0;
    x_ = 0.0;
    return Eigen::VectorXd::Constant(1, x_);
  }
  StepResult step(const Eigen::VectorXd& action) override {
    x_ += action[0];
    ++t_;
    StepResult r;
    r.observation = Eigen::VectorXd::Constant(1, x_);
    r.reward = x_;
    r.truncated = t_ == spec_.horizon;
    return r;
  }
  bool in_failure_state() const override {
    if (seed_ % 2 == 1) return t_ == spec_.horizon;
    return seed_ % 5 == 0 && t_ >= 3 && t_ < 6;
  }

 private:
  EnvSpec spec_;
  std::uint64_t seed_ = 0;
  int t_ = 0;
  double x_ = 0.0;
};

// A 1-1 linear expert that always asks for action 2 (clipped to 1 by the env): every episode returns 55.
TaskExpert constant_expert(const std::string& task) {
  ExpertPolicy p;
  p.task = task;
  p.obs_mean = Eigen::VectorXd::Zero(1);
  p.obs_var = Eigen::VectorXd::Ones(1);
  p.weights = {Eigen::MatrixXd::Zero(1, 1)};
  p.biases = {Eigen::VectorXd::Constant(1, 2.0)};
  p.log_std = Eigen::VectorXd::Constant(1, -1.0);
  return task_expert_from_policy(p, "constant");
}

TEST(DemoCollection, DiscardsFailedEpisodesAndRecordsWhy) {
  FakeEnv env;
  DemoCollectionConfig config;
  config.demos = 4;
  const TaskDemonstrations out = collect_task_demonstrations(env, constant_expert("fake/walker"), config);
  ASSERT_EQ(out.demos.size(), 4u);
  // Kept: 2, 4, 6, 8 (0 spent 30% of its steps failed; odd seeds ended failed).
  const std::uint64_t kept[4] = {2, 4, 6, 8};
  for (int i = 0; i < 4; ++i) {
    const Demonstration& d = out.demos[i];
    EXPECT_EQ(d.seed, kept[i]);
    EXPECT_EQ(d.task, "fake/walker");
    EXPECT_EQ(d.task_index, 2);
    ASSERT_EQ(d.num_samples(), 10);
    EXPECT_DOUBLE_EQ(d.obs(0, 0), 0.0);  // row t is the observation step t's action saw
    EXPECT_DOUBLE_EQ(d.obs(9, 0), 9.0);
    EXPECT_DOUBLE_EQ(d.actions(0, 0), 1.0);  // the applied (clipped) action, not the expert's 2
    EXPECT_DOUBLE_EQ(d.episode_return, 55.0);
    EXPECT_EQ(d.dones[8], 0);
    EXPECT_EQ(d.dones[9], 1);
  }
  EXPECT_DOUBLE_EQ(out.median_return, 55.0);
  ASSERT_EQ(out.discarded.size(), 5u);  // 0, 1, 3, 5, 7
  EXPECT_EQ(out.discarded[0].seed, 0u);
  EXPECT_THAT(out.discarded[0].reason, HasSubstr("30.0% of its steps in the failure state"));
  EXPECT_EQ(out.discarded[1].seed, 1u);
  EXPECT_THAT(out.discarded[1].reason, HasSubstr("ended in the failure state"));
}

TEST(DemoCollection, RequireSuccessDiscardsEpisodesThatNeverSucceed) {
  FakeEnv env;  // never reports success
  DemoCollectionConfig config;
  config.demos = 2;
  config.require_success = true;
  config.max_attempts_factor = 2;
  EXPECT_THAT([&] { collect_task_demonstrations(env, constant_expert("fake/walker"), config); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("never met the success test")));
}

TEST(DemoCollection, AnExpertGivingWrongSizedActionsIsNamed) {
  FakeEnv env;
  TaskExpert expert = constant_expert("fake/walker");
  expert.source = "broken.json";
  expert.mean_action = [](const Eigen::VectorXd&) { return Eigen::VectorXd::Zero(3); };
  DemoCollectionConfig config;
  config.demos = 1;
  EXPECT_THAT([&] { collect_task_demonstrations(env, expert, config); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("broken.json")));
}

TEST(DemoCollection, GivesUpNamingTheTaskWhenTooFewEpisodesPass) {
  FakeEnv env;
  DemoCollectionConfig config;
  config.demos = 4;
  config.max_failure_fraction = 0.0;
  config.max_attempts_factor = 1;
  try {
    collect_task_demonstrations(env, constant_expert("fake/walker"), config);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_THAT(e.what(), HasSubstr("fake/walker"));
    EXPECT_THAT(e.what(), HasSubstr("only 1 of 4 episodes"));
    EXPECT_THAT(e.what(), HasSubstr("seed 0:"));
  }
}

TEST(DemoCollection, RejectsMismatchedExpertAndBadConfig) {
  FakeEnv env;
  DemoCollectionConfig config;
  EXPECT_THAT([&] { collect_task_demonstrations(env, constant_expert("gravity/0.5"), config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("trained on 'gravity/0.5'")));
  config.demos = 0;
  EXPECT_THAT([&] { collect_task_demonstrations(env, constant_expert("fake/walker"), config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("demos must be >= 1")));
  config.demos = 3;
  config.first_seed = kEvalSeedBegin - 5;
  EXPECT_THAT([&] { collect_task_demonstrations(env, constant_expert("fake/walker"), config); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("evaluation range")));
  EXPECT_THROW(parse_demo_actions("greedy"), std::invalid_argument);
  EXPECT_EQ(parse_demo_actions("sample"), DemoActions::kSample);
  EXPECT_EQ(to_string(DemoActions::kMean), "mean");
}

// With the committed gravity/1.0 expert: demonstrations replay exactly, sampled actions are reproducible and
// differ from the mean's, and the quality bar holds on the real task.
class CheetahDemos : public ::testing::Test {
 protected:
  void SetUp() override {
    env_ = make_env("gravity/1.0");
    expert_ = load_task_expert("gravity/1.0");
  }
  std::unique_ptr<Env> env_;
  TaskExpert expert_;
};

TEST_F(CheetahDemos, ReplayingTheRecordedActionsReproducesTheDemonstration) {
  DemoCollectionConfig config;
  config.demos = 2;
  const TaskDemonstrations out = collect_task_demonstrations(*env_, expert_, config);
  ASSERT_EQ(out.demos.size(), 2u);
  for (const Demonstration& d : out.demos) {
    ASSERT_EQ(d.num_samples(), 1000);
    EXPECT_GT(d.episode_return, 3000.0);
    EXPECT_LE(d.actions.cwiseAbs().maxCoeff(), 1.0);
    Eigen::VectorXd obs = env_->reset(d.seed);
    StepResult r;
    for (int t = 0; t < 1000; ++t) {
      ASSERT_EQ(obs, d.obs.row(t).transpose()) << "step " << t;
      r = env_->step(d.actions.row(t).transpose());
      ASSERT_EQ(r.reward, d.rewards[t]) << "step " << t;
      obs = r.observation;
    }
    // The last step's observation and how the episode ended (next_obs's last row and episode_end in the file).
    EXPECT_EQ(d.final_obs, obs);
    EXPECT_TRUE(r.truncated);
    EXPECT_EQ(d.end, EpisodeEnd::kTruncated);
  }
}

TEST_F(CheetahDemos, SampledActionsAreReproducibleAndNoisy) {
  DemoCollectionConfig config;
  config.demos = 1;
  config.actions = DemoActions::kSample;
  const TaskDemonstrations a = collect_task_demonstrations(*env_, expert_, config);
  const TaskDemonstrations b = collect_task_demonstrations(*env_, expert_, config);
  ASSERT_EQ(a.demos.size(), 1u);
  EXPECT_EQ(a.demos[0].actions, b.demos[0].actions);
  config.noise_seed = 1;
  const TaskDemonstrations c = collect_task_demonstrations(*env_, expert_, config);
  EXPECT_NE(a.demos[0].actions, c.demos[0].actions);
  // Step 0 sees the same state either way; the sampled action differs from the mean by the expert's noise.
  const Eigen::VectorXd mean = expert_.mean_action(a.demos[0].obs.row(0).transpose());
  EXPECT_GT((a.demos[0].actions.row(0).transpose() - mean.cwiseMax(-1.0).cwiseMin(1.0)).norm(), 0.0);
}

}  // namespace
}  // namespace maps::envs
