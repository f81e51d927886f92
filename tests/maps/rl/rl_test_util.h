#pragma once

// Shared helpers of the rl tests: a tiny deterministic env.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "envs/env.h"

namespace rltest {

// A point on a line that should move to a target. obs = (x, target), action a in [-1, 1] moves x by 0.1 a;
// reward 1 - |x - target|; the episode is truncated after 50 steps and terminated when |x| > 1.5. x and target
// start uniform in [-1, 1] from the reset seed.
class PointEnv : public maps::envs::Env {
 public:
  PointEnv() : spec_(maps::envs::unit_box_spec("toy/point", 0, 2, 1, 50)) {}
  const maps::envs::EnvSpec& spec() const override { return spec_; }
  Eigen::VectorXd reset(std::uint64_t seed) override {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    x_ = u(rng);
    target_ = u(rng);
    t_ = 0;
    active_ = true;
    return obs();
  }
  maps::envs::StepResult step(const Eigen::VectorXd& action) override {
    if (!active_) throw std::logic_error("PointEnv: step without reset");
    if (action.size() != 1 || std::isnan(action(0))) throw std::invalid_argument("PointEnv: bad action");
    x_ += 0.1 * std::clamp(action(0), -1.0, 1.0);
    ++t_;
    maps::envs::StepResult r;
    r.observation = obs();
    r.reward = 1.0 - std::abs(x_ - target_);
    r.terminated = std::abs(x_) > 1.5;
    r.truncated = !r.terminated && t_ >= spec_.horizon;
    if (r.done()) active_ = false;
    return r;
  }

 private:
  Eigen::VectorXd obs() const { return Eigen::Vector2d(x_, target_); }
  maps::envs::EnvSpec spec_;
  double x_ = 0.0, target_ = 0.0;
  int t_ = 0;
  bool active_ = false;
};

// A pole whose angle the action tilts by 0.3 a per step; reward 1 per step, 50 steps; obs = (angle, 0).
// The angle sits at observation index 0, standing in for HalfCheetah's torso pitch.
class TiltEnv : public maps::envs::Env {
 public:
  TiltEnv() : spec_(maps::envs::unit_box_spec("toy/tilt", 0, 2, 1, 50)) {}
  const maps::envs::EnvSpec& spec() const override { return spec_; }
  Eigen::VectorXd reset(std::uint64_t seed) override {
    std::mt19937_64 rng(seed);
    angle_ = std::uniform_real_distribution<double>(-0.5, 0.5)(rng);
    t_ = 0;
    return Eigen::Vector2d(angle_, 0.0);
  }
  maps::envs::StepResult step(const Eigen::VectorXd& action) override {
    angle_ += 0.3 * std::clamp(action(0), -1.0, 1.0);
    maps::envs::StepResult r;
    r.observation = Eigen::Vector2d(angle_, 0.0);
    r.reward = 1.0;
    r.truncated = ++t_ >= spec_.horizon;
    return r;
  }

 private:
  maps::envs::EnvSpec spec_;
  double angle_ = 0.0;
  int t_ = 0;
};

}  // namespace rltest
