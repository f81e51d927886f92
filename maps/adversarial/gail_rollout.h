#pragma once

#include <Eigen/Core>
#include <chrono>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "autograd/autograd.h"
#include "envs/env.h"
#include "maps/data/standardizer.h"
#include "maps/policies/policy.h"

// One GAIL iteration's episodes: every task's envs stepped in lockstep, one policy call for all running episodes a
// step, actions drawn from N(mean, exp(log_std)^2), the envs stepped on ag::num_threads() threads.
namespace maps::adversarial {

// Wall seconds since `start` (the rollout's and the trainer's phase timings).
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

struct RolloutTimes {
  double physics_seconds = 0.0;  // env resets and steps (wall time of the parallel stepping)
  double policy_seconds = 0.0;   // standardising, the policy's calls and the draws
};

// Rows of all episodes, episode after episode, each in time order.
struct Rollout {
  ag::RowMatrixF observations;           // [N, S] standardised, float32 as the policy sees them
  ag::RowMatrixF previous_observations;  // [N, S] the state before each one (itself at an episode's start)
  ag::RowMatrixF actions;                // [N, A] drawn (what log_probs are of)
  ag::RowMatrixF executed_actions;       // [N, A] clipped to the env's bounds (what the env and the discriminator get)
  std::vector<std::int64_t> tasks;       // [N]
  Eigen::VectorXd log_probs;             // [N] under the policy that drew them
  Eigen::VectorXd env_rewards;           // [N] the env's own reward, for the curves only
  // Per episode: its first row, its length, whether its last step was a real terminal (no bootstrap), the
  // standardised observation after its last step, its task, its env return and whether success held at any step.
  std::vector<std::int64_t> episode_start, episode_length, episode_task;
  std::vector<bool> episode_terminated, episode_success;
  std::vector<double> episode_return;
  ag::RowMatrixF final_observations;  // [episodes, S]
  // Rows of each task, in order.
  std::vector<std::vector<std::int64_t>> task_rows;

  std::int64_t rows() const { return static_cast<std::int64_t>(tasks.size()); }
};

// Runs one episode in each env (envs[i] is of task env_tasks[i]; seeds[i] its reset seed). `noise` draws the
// actions' Gaussian noise, in env order at every step (so the rollout is the same for any thread count). A
// non-finite mean action is an error naming the task.
Rollout collect_rollout(const std::vector<std::unique_ptr<envs::Env>>& envs, const std::vector<std::int64_t>& env_tasks,
                        const std::vector<std::uint64_t>& seeds, core::Policy& policy, const ag::Tensor& log_std,
                        const core::Standardizer& standardizer, std::int64_t num_tasks, ag::Generator& noise,
                        RolloutTimes& times);

}  // namespace maps::adversarial
