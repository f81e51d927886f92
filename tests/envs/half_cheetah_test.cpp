#include "envs/half_cheetah.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace maps::envs {
namespace {

using ::testing::HasSubstr;

// A fixed, varied action sequence (some entries outside [-1, 1]).
Eigen::VectorXd action_at(int t) {
  Eigen::VectorXd a(6);
  for (int j = 0; j < 6; ++j) a[j] = 1.3 * std::sin(0.37 * t + 1.1 * j);
  return a;
}

std::vector<Eigen::VectorXd> rollout(HalfCheetahEnv& env, std::uint64_t seed, int steps, std::vector<double>* rewards) {
  std::vector<Eigen::VectorXd> observations{env.reset(seed)};
  for (int t = 0; t < steps; ++t) {
    const StepResult r = env.step(action_at(t));
    observations.push_back(r.observation);
    rewards->push_back(r.reward);
  }
  return observations;
}

TEST(HalfCheetah, Spec) {
  const HalfCheetahEnv env("test/cheetah", 3);
  EXPECT_EQ(env.spec().task, "test/cheetah");
  EXPECT_EQ(env.spec().task_index, 3);
  EXPECT_EQ(env.spec().observation_size, 17);
  EXPECT_EQ(env.spec().action_size, 6);
  EXPECT_EQ(env.spec().horizon, 1000);
  EXPECT_EQ(env.spec().action_low, Eigen::VectorXd::Constant(6, -1.0));
  EXPECT_EQ(env.spec().action_high, Eigen::VectorXd::Constant(6, 1.0));
  EXPECT_DOUBLE_EQ(env.dt(), 0.05);
  EXPECT_EQ(env.frame_skip(), 5);
}

TEST(HalfCheetah, CompiledModelMatchesReference) {
  const HalfCheetahEnv env("test/cheetah", 0);
  const mjModel* m = env.model();
  EXPECT_EQ(m->nq, 9);
  EXPECT_EQ(m->nv, 9);
  EXPECT_EQ(m->nu, 6);
  EXPECT_EQ(m->nbody, 8);
  EXPECT_EQ(m->ngeom, 9);
  EXPECT_DOUBLE_EQ(m->opt.timestep, 0.01);
  EXPECT_EQ(m->opt.integrator, 0);  // Euler
  const double gears[6] = {120, 90, 60, 120, 60, 30};
  for (int i = 0; i < 6; ++i) EXPECT_DOUBLE_EQ(m->actuator_gear[6 * i], gears[i]) << i;
  // Leg joints: stiffness, damping, armature and ranges (cheetah.md §1.1).
  const char* joints[6] = {"bthigh", "bshin", "bfoot", "fthigh", "fshin", "ffoot"};
  const double stiffness[6] = {240, 180, 120, 180, 120, 60};
  const double damping[6] = {6, 4.5, 3, 4.5, 3, 1.5};
  const double low[6] = {-0.52, -0.785, -0.4, -1, -1.2, -0.5};
  const double high[6] = {1.05, 0.785, 0.785, 0.7, 0.87, 0.5};
  for (int i = 0; i < 6; ++i) {
    const int j = mj_name2id(m, mjOBJ_JOINT, joints[i]);
    ASSERT_GE(j, 0) << joints[i];
    EXPECT_DOUBLE_EQ(m->jnt_stiffness[j], stiffness[i]) << joints[i];
    EXPECT_DOUBLE_EQ(m->dof_damping[m->jnt_dofadr[j]], damping[i]) << joints[i];
    EXPECT_DOUBLE_EQ(m->dof_armature[m->jnt_dofadr[j]], 0.1) << joints[i];
    EXPECT_TRUE(m->jnt_limited[j]) << joints[i];
    EXPECT_DOUBLE_EQ(m->jnt_range[2 * j], low[i]) << joints[i];
    EXPECT_DOUBLE_EQ(m->jnt_range[2 * j + 1], high[i]) << joints[i];
  }
  for (const char* root : {"rootx", "rootz", "rooty"}) {
    const int j = mj_name2id(m, mjOBJ_JOINT, root);
    EXPECT_FALSE(m->jnt_limited[j]) << root;
    EXPECT_EQ(m->jnt_stiffness[j], 0.0) << root;
    EXPECT_EQ(m->dof_damping[m->jnt_dofadr[j]], 0.0) << root;
    EXPECT_EQ(m->dof_armature[m->jnt_dofadr[j]], 0.0) << root;
  }
}

TEST(HalfCheetah, BaseMassesMatchMujoco222Table) {
  // cheetah.md §1.1, measured on gym's XML in MuJoCo 2.2.2 (exact capsule volumes).
  const HalfCheetahEnv env("test/cheetah", 0);
  const mjModel* m = env.model();
  const char* bodies[7] = {"torso", "bthigh", "bshin", "bfoot", "fthigh", "fshin", "ffoot"};
  const double mass[7] = {6.250209, 1.543515, 1.587448, 1.095397, 1.438075, 1.200837, 0.884519};
  double total = 0.0;
  for (int i = 0; i < 7; ++i) {
    const int b = mj_name2id(m, mjOBJ_BODY, bodies[i]);
    ASSERT_GE(b, 0) << bodies[i];
    EXPECT_NEAR(m->body_mass[b], mass[i], 2e-6) << bodies[i];
    total += m->body_mass[b];
  }
  EXPECT_NEAR(total, 14.0, 1e-9);
  const int torso = mj_name2id(m, mjOBJ_BODY, "torso");
  EXPECT_NEAR(m->body_inertia[3 * torso], 0.897118, 2e-6);
  EXPECT_NEAR(m->body_inertia[3 * torso + 1], 0.885655, 2e-6);
  EXPECT_NEAR(m->body_inertia[3 * torso + 2], 0.0179609, 2e-7);
  EXPECT_NEAR(m->body_ipos[3 * torso], 0.1524, 1e-4);
  EXPECT_NEAR(m->body_ipos[3 * torso + 2], 0.0254, 1e-4);
}

TEST(HalfCheetah, SameSeedGivesBitwiseIdenticalTrajectory) {
  HalfCheetahEnv a("test/cheetah", 0);
  HalfCheetahEnv b("test/cheetah", 0);
  std::vector<double> rewards_a, rewards_b;
  const auto obs_a = rollout(a, 42, 200, &rewards_a);
  const auto obs_b = rollout(b, 42, 200, &rewards_b);
  ASSERT_EQ(obs_a.size(), obs_b.size());
  for (std::size_t t = 0; t < obs_a.size(); ++t) ASSERT_EQ(obs_a[t], obs_b[t]) << "step " << t;
  EXPECT_EQ(rewards_a, rewards_b);
  // The same env reset again reproduces it too (no state leaks between episodes).
  std::vector<double> rewards_again;
  const auto obs_again = rollout(a, 42, 200, &rewards_again);
  for (std::size_t t = 0; t < obs_a.size(); ++t) ASSERT_EQ(obs_a[t], obs_again[t]) << "step " << t;
}

TEST(HalfCheetah, DifferentSeedsGiveDifferentInitialStates) {
  HalfCheetahEnv env("test/cheetah", 0);
  const Eigen::VectorXd first = env.reset(1);
  const Eigen::VectorXd second = env.reset(2);
  EXPECT_NE(first, second);
  EXPECT_TRUE((first - second).cwiseAbs().minCoeff() > 0.0);
}

TEST(HalfCheetah, ResetNoiseHasTheStandardScale) {
  HalfCheetahEnv env("test/cheetah", 0);
  double qvel_sq = 0.0;
  int n = 0;
  for (std::uint64_t seed = 0; seed < 200; ++seed) {
    env.reset(seed);
    for (int i = 0; i < 9; ++i) {
      EXPECT_LE(std::abs(env.data()->qpos[i]), 0.1);
      qvel_sq += env.data()->qvel[i] * env.data()->qvel[i];
      ++n;
    }
  }
  EXPECT_NEAR(std::sqrt(qvel_sq / n), 0.1, 0.01);
}

TEST(HalfCheetah, ObservationIsQposWithoutRootXThenQvel) {
  HalfCheetahEnv env("test/cheetah", 0);
  const Eigen::VectorXd obs = env.reset(7);
  ASSERT_EQ(obs.size(), 17);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(obs[i], env.data()->qpos[i + 1]);
  for (int i = 0; i < 9; ++i) EXPECT_EQ(obs[8 + i], env.data()->qvel[i]);
  EXPECT_EQ(env.pitch(), obs[1]);
}

TEST(HalfCheetah, RewardIsForwardVelocityMinusControlCost) {
  HalfCheetahEnv env("test/cheetah", 0);
  env.reset(3);
  const Eigen::VectorXd action = (Eigen::VectorXd(6) << 0.5, -0.25, 1.0, -1.0, 0.1, 0.0).finished();
  const double x_before = env.x_position();
  const StepResult r = env.step(action);
  const double expected = (env.x_position() - x_before) / 0.05 - 0.1 * action.squaredNorm();
  EXPECT_DOUBLE_EQ(r.reward, expected);
  EXPECT_FALSE(r.terminated);
  EXPECT_FALSE(r.truncated);
  EXPECT_FALSE(r.success);
}

TEST(HalfCheetah, OutOfRangeActionIsClippedIncludingControlCost) {
  HalfCheetahEnv a("test/cheetah", 0);
  HalfCheetahEnv b("test/cheetah", 0);
  a.reset(5);
  b.reset(5);
  const Eigen::VectorXd wild = (Eigen::VectorXd(6) << 3.0, -7.0, 0.5, 1e9, -1.5, -0.2).finished();
  const Eigen::VectorXd clipped = (Eigen::VectorXd(6) << 1.0, -1.0, 0.5, 1.0, -1.0, -0.2).finished();
  const StepResult ra = a.step(wild);
  const StepResult rb = b.step(clipped);
  EXPECT_EQ(ra.observation, rb.observation);
  EXPECT_EQ(ra.reward, rb.reward);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(a.data()->ctrl[i], clipped[i]);
  // Infinities are clipped too (only NaN is an error).
  HalfCheetahEnv c("test/cheetah", 0);
  c.reset(5);
  Eigen::VectorXd infinite = clipped;
  infinite[0] = std::numeric_limits<double>::infinity();
  EXPECT_EQ(c.step(infinite).observation, rb.observation);
}

// Gym charges the control cost on the action as given; the step reports that difference beside the reward.
TEST(HalfCheetah, ReportsTheExtraControlCostGymWouldChargeOnTheUnclippedAction) {
  HalfCheetahEnv env("test/cheetah", 0);
  env.reset(5);
  const Eigen::VectorXd inside = (Eigen::VectorXd(6) << 0.5, -0.25, 1.0, -1.0, 0.1, 0.0).finished();
  EXPECT_EQ(env.step(inside).unclipped_control_cost, 0.0);
  const Eigen::VectorXd wild = (Eigen::VectorXd(6) << 3.0, -2.0, 0.5, 0.0, -1.5, -0.2).finished();
  // 0.1 * ((9 + 4 + 2.25) - (1 + 1 + 1)) over the entries past the bounds.
  EXPECT_NEAR(env.step(wild).unclipped_control_cost, 0.1 * (15.25 - 3.0), 1e-12);
}

TEST(HalfCheetah, NanActionIsAnErrorNamingTheTask) {
  HalfCheetahEnv env("gravity/0.5", 0);
  env.reset(0);
  Eigen::VectorXd action = Eigen::VectorXd::Zero(6);
  action[2] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT([&] { env.step(action); }, ::testing::ThrowsMessage<std::invalid_argument>(
                                             ::testing::AllOf(HasSubstr("gravity/0.5"), HasSubstr("NaN"))));
}

TEST(HalfCheetah, WrongSizedActionIsAnErrorNamingTheTask) {
  HalfCheetahEnv env("modified/big_foot", 0);
  env.reset(0);
  EXPECT_THAT([&] { env.step(Eigen::VectorXd::Zero(5)); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::AllOf(HasSubstr("modified/big_foot"), HasSubstr("5"), HasSubstr("6"))));
}

TEST(HalfCheetah, StepBeforeResetIsAnError) {
  HalfCheetahEnv env("test/cheetah", 0);
  EXPECT_THAT([&] { env.step(Eigen::VectorXd::Zero(6)); },
              ::testing::ThrowsMessage<std::logic_error>(HasSubstr("test/cheetah")));
}

TEST(HalfCheetah, TruncatesExactlyAtStep1000AndThenRefusesToStep) {
  HalfCheetahEnv env("test/cheetah", 0);
  env.reset(11);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(6);
  for (int t = 1; t < 1000; ++t) {
    const StepResult r = env.step(zero);
    ASSERT_FALSE(r.done()) << "step " << t;
  }
  const StepResult last = env.step(zero);
  EXPECT_TRUE(last.truncated);
  EXPECT_FALSE(last.terminated);
  EXPECT_EQ(env.elapsed_steps(), 1000);
  EXPECT_THROW(env.step(zero), std::logic_error);
  env.reset(12);  // a new episode may start
  EXPECT_FALSE(env.step(zero).done());
}

TEST(HalfCheetah, FlipDetectionUsesTorsoOrientation) {
  HalfCheetahEnv env("test/cheetah", 0);
  env.reset(0);
  EXPECT_FALSE(env.is_flipped());
  const Eigen::VectorXd qvel = Eigen::VectorXd::Zero(9);
  const auto with_pitch = [&](double pitch) {
    Eigen::VectorXd qpos = Eigen::VectorXd::Zero(9);
    qpos[2] = pitch;
    env.set_state(qpos, qvel);
    return env.is_flipped();
  };
  EXPECT_FALSE(with_pitch(1.0));  // a steep but upright gait
  EXPECT_TRUE(with_pitch(3.0));   // on its back
  EXPECT_TRUE(with_pitch(-2.0));
  EXPECT_FALSE(with_pitch(2 * M_PI + 0.3));  // a full somersault and upright again
}

TEST(HalfCheetah, UnknownGeomInVariantIsAnError) {
  HalfCheetahVariant variant;
  variant.geom_size_scale["tail"] = 1.25;
  EXPECT_THAT([&] { HalfCheetahEnv("test/tail", 0, variant); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("tail")));
}

}  // namespace
}  // namespace maps::envs
