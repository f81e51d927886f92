#include "maps/rl/ppo.h"

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <numbers>
#include <numeric>
#include <sstream>

#include "rl_test_util.h"

namespace rltest {
namespace {

namespace rl = maps::rl;

double mean_of(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / v.size(); }

rl::PPOConfig toy_config(std::int64_t total_steps) {
  rl::PPOConfig c;
  c.total_steps = total_steps;
  c.steps_per_rollout = 512;
  c.seed = 11;
  return c;
}

std::string fresh_dir(const std::string& name) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("maps_ppo_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  return dir.string();
}

TEST(PPO, ImprovesTheReturnOnAToyTask) {
  PointEnv env, eval_env;
  rl::PPOTrainer trainer(env, toy_config(8192));
  const double before = mean_of(rl::evaluate_policy(eval_env, trainer.model(), trainer.observation_stats(), 20, 1000));
  const auto start = std::chrono::steady_clock::now();
  trainer.train();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double after = mean_of(rl::evaluate_policy(eval_env, trainer.model(), trainer.observation_stats(), 20, 1000));
  RecordProperty("env_steps_per_second", std::to_string(static_cast<int>(trainer.steps_done() / seconds)));
  std::printf("toy PPO: deterministic return %.2f -> %.2f in %lld steps, %.0f env steps/s\n", before, after,
              static_cast<long long>(trainer.steps_done()), trainer.steps_done() / seconds);
  EXPECT_EQ(trainer.steps_done(), 8192);
  EXPECT_EQ(trainer.iterations_done(), 16);
  EXPECT_GT(after, before + 10.0);
  EXPECT_GT(after, 35.0);  // moving straight to the target and staying scores about 47
}

// Trains a run of 4 iterations straight through and one stopped after 3 and resumed, and expects them identical.
template <typename EnvT>
void expect_resume_matches_an_uninterrupted_run(rl::PPOConfig config, const std::string& name) {
  const std::string dir_a = fresh_dir(name + "_a"), dir_b = fresh_dir(name + "_b");
  config.total_steps = 4 * config.steps_per_rollout;
  config.checkpoint_every = 1;
  EnvT env_a;
  rl::PPOTrainer a(env_a, config, dir_a);
  EXPECT_EQ(a.train(), 4);

  {
    EnvT env_b1;
    rl::PPOTrainer b1(env_b1, config, dir_b);
    EXPECT_EQ(b1.train(3), 3);
  }
  EnvT env_b2;
  std::ostringstream log;
  rl::PPOTrainer b2(env_b2, config, dir_b, &log);
  EXPECT_EQ(b2.train(), 1);
  EXPECT_THAT(log.str(), ::testing::HasSubstr("resumed from"));
  EXPECT_EQ(b2.steps_done(), a.steps_done());

  const auto sa = a.model().state_dict(), sb = b2.model().state_dict();
  ASSERT_EQ(sa.size(), sb.size());
  for (std::size_t i = 0; i < sa.size(); ++i)
    EXPECT_EQ(sa[i].tensor.to_vector(), sb[i].tensor.to_vector()) << sa[i].name;
  EXPECT_EQ(a.observation_stats().mean(), b2.observation_stats().mean());
  EXPECT_EQ(a.observation_stats().var(), b2.observation_stats().var());
  EXPECT_EQ(a.recent_mean_return(), b2.recent_mean_return());

  // A finished run resumes to nothing left to do.
  EnvT env_c;
  rl::PPOTrainer c(env_c, config, dir_a);
  EXPECT_EQ(c.train(), 0);
  EXPECT_EQ(c.iterations_done(), 4);
  std::filesystem::remove_all(dir_a);
  std::filesystem::remove_all(dir_b);
}

TEST(PPO, ResumedRunMatchesAnUninterruptedOne) {
  // The rollouts straddle episodes (512 is not a multiple of 50), so the resume must rebuild one in progress.
  expect_resume_matches_an_uninterrupted_run<PointEnv>(toy_config(512), "point");
}

TEST(PPO, ResumedRunMatchesAnUninterruptedOneWhenEpisodesEndAtAPitch) {
  rl::PPOConfig config = toy_config(512);
  config.pitch_index = 0;
  config.end_episode_at_pitch = 0.8;
  expect_resume_matches_an_uninterrupted_run<TiltEnv>(config, "tilt");
}

TEST(PPO, ResumingWithAnotherRecipeIsRefusedNamingTheSetting) {
  const std::string dir = fresh_dir("recipe");
  rl::PPOConfig config = toy_config(2 * 512);
  config.pitch_index = 0;
  {
    TiltEnv env;
    rl::PPOTrainer t(env, config, dir);
    t.train(1);
  }
  config.end_episode_at_pitch = 0.8;
  TiltEnv env;
  rl::PPOTrainer t(env, config, dir);
  EXPECT_THAT([&] { t.train(); },
              ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr("end_episode_at_pitch = 0.0")));
  // The step budget may change (a run extended further).
  config.end_episode_at_pitch = 0.0;
  config.total_steps = 3 * 512;
  TiltEnv env_longer;
  rl::PPOTrainer longer(env_longer, config, dir);
  EXPECT_EQ(longer.train(), 2);
  std::filesystem::remove_all(dir);
}

TEST(PPO, CheckpointOfAnotherTaskIsRefused) {
  const std::string dir = fresh_dir("other");
  rl::PPOConfig config = toy_config(512);
  {
    PointEnv env;
    rl::PPOTrainer t(env, config, dir);
    t.train();
  }
  class OtherEnv : public PointEnv {
   public:
    OtherEnv() { spec_copy_ = PointEnv::spec(), spec_copy_.task = "toy/other"; }
    const maps::envs::EnvSpec& spec() const override { return spec_copy_; }
    maps::envs::EnvSpec spec_copy_;
  } other;
  rl::PPOTrainer t(other, config, dir);
  EXPECT_THROW(t.train(), std::runtime_error);
  std::filesystem::remove_all(dir);
}

// Rewards turn NaN after 700 steps: the second iteration's loss is not finite, which must stop training with a
// clear error and leave the checkpoint of the first iteration in place.
TEST(PPO, NonFiniteLossStopsAndKeepsTheLastGoodCheckpoint) {
  class NanEnv : public PointEnv {
   public:
    maps::envs::StepResult step(const Eigen::VectorXd& action) override {
      maps::envs::StepResult r = PointEnv::step(action);
      if (++steps_ > 700) r.reward = std::nan("");
      return r;
    }
    int steps_ = 0;
  } env;
  const std::string dir = fresh_dir("nan");
  rl::PPOConfig config = toy_config(4 * 512);
  config.checkpoint_every = 1;
  rl::PPOTrainer t(env, config, dir);
  std::string message;
  try {
    t.train();
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  EXPECT_THAT(message, ::testing::HasSubstr("not finite"));
  EXPECT_THAT(message, ::testing::HasSubstr("iteration 2"));
  PointEnv fresh;
  rl::PPOTrainer resumed(fresh, config, dir);
  EXPECT_TRUE(resumed.resume());
  EXPECT_EQ(resumed.iterations_done(), 1);
  for (const auto& p : resumed.model().parameters())
    for (double v : p.to_vector()) ASSERT_TRUE(std::isfinite(v));
  std::filesystem::remove_all(dir);
}

rl::PPOConfig tilt_config(bool end_when_flipped) {
  rl::PPOConfig c = toy_config(512);
  c.pitch_index = 0;
  c.end_episode_at_pitch = end_when_flipped ? std::numbers::pi / 2 : 0.0;
  return c;
}

TEST(PPO, EndsTrainingEpisodesWhenTheTorsoTurnsOverOnlyWhenAsked) {
  TiltEnv env_keep, env_end;
  rl::PPOTrainer keep(env_keep, tilt_config(false)), end(env_end, tilt_config(true));
  keep.train();
  end.train();
  // Without the option every episode runs its 50 steps; with it, the random walk of the untrained policy
  // (action std 1) turns over (|angle| > pi/2) within the horizon in many episodes.
  EXPECT_EQ(keep.history().back().episodes_finished, 512 / 50);
  EXPECT_DOUBLE_EQ(keep.recent_mean_return(), 50.0);
  EXPECT_GT(end.history().back().episodes_finished, 512 / 50 + 2);
  EXPECT_LT(end.recent_mean_return(), 45.0);
  // ... and no action is ever taken turned over, which the untrained policy without the option does.
  EXPECT_GT(keep.history().back().flipped_fraction, 0.0);
  EXPECT_EQ(end.history().back().flipped_fraction, 0.0);
  // A smaller angle ends episodes sooner: more of them fit in the rollout.
  TiltEnv env_early;
  rl::PPOConfig early_config = tilt_config(true);
  early_config.end_episode_at_pitch = 0.6;
  rl::PPOTrainer early(env_early, early_config);
  early.train();
  EXPECT_GT(early.history().back().episodes_finished, end.history().back().episodes_finished);
}

TEST(PPO, EndingEpisodesWhenFlippedTeachesThePolicyToStayUpright) {
  TiltEnv env;
  rl::PPOConfig config = tilt_config(true);
  config.total_steps = 16 * 512;
  rl::PPOTrainer trainer(env, config);
  trainer.train(1);
  const double first = trainer.recent_mean_return();
  trainer.train();
  const double last = trainer.recent_mean_return();
  std::printf("tilt PPO with episodes ending when flipped: training return %.1f -> %.1f\n", first, last);
  EXPECT_GT(last, first + 10.0);
  EXPECT_GT(last, 45.0);
}

TEST(PPO, EndingEpisodesAtAPitchNeedsThePitchIndexAndAnAngleUpToPi) {
  TiltEnv env;
  rl::PPOConfig config = tilt_config(true);
  config.pitch_index = -1;
  EXPECT_THAT([&] { rl::PPOTrainer t(env, config); },
              ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("pitch_index")));
  for (double angle : {-0.1, std::numbers::pi, 4.0, std::nan("")}) {
    config = tilt_config(true);
    config.end_episode_at_pitch = angle;
    EXPECT_THAT([&] { rl::PPOTrainer t(env, config); },
                ::testing::ThrowsMessage<std::invalid_argument>(::testing::HasSubstr("[0, pi)")))
        << angle;
  }
}

}  // namespace
}  // namespace rltest
