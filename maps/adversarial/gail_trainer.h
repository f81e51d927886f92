#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>

#include "maps/adversarial/gail_config.h"
#include "maps/data/demo_dataset.h"
#include "maps/evaluation/evaluator.h"
#include "maps/policies/policy.h"

// GAIL (Ho and Ermon, 2016) for any Policy: each iteration runs rollout_episodes episodes of every task with a
// Gaussian around the policy's mean action (a learned state-independent log std), takes discriminator steps on
// demonstration pairs against the rollout's, rewards the rollout with the updated discriminator, and takes PPO
// epochs on it, the method's own regularisers (MAPS's selector losses) and an optional BC term added to the PPO loss.
//
// The run folder holds last.ckpt (policy, the Gaussian head and critic, discriminator, both Adam states, the reward
// normalisers, the RNG, the iteration: a resumed run continues bit for bit as one that was never stopped; every
// rollout is consumed by its own iteration, so nothing else is carried), best.ckpt (the policy, as a BC run's, so
// `maps eval` scores it), and curve.csv (one row per iteration).
namespace maps::adversarial {

struct GailSummary {
  std::int64_t iterations = 0;          // done in total (this process and the ones before)
  std::int64_t env_steps_per_task = 0;  // done in total
  std::int64_t best_iteration = 0;
  double best_validation_loss = 0.0;  // the mean action error of best.ckpt's policy on the validation states
  bool resumed = false;
  // This process's wall time and where it went: stepping the envs (physics), the policy's calls during rollouts,
  // the discriminator's steps and rewards, PPO's epochs (with the critic), validation and checkpoints.
  double seconds = 0.0;
  double physics_seconds = 0.0, rollout_policy_seconds = 0.0, discriminator_seconds = 0.0, ppo_seconds = 0.0,
         other_seconds = 0.0;
  std::int64_t env_steps_this_process = 0;  // summed over tasks
};

// The reset seed of episode `episode` of task `task` in a GAIL run seeded `seed`: in [kRolloutSeedBegin,
// kRolloutSeedBegin + 2^50), above the demonstration and evaluation seeds (envs/seed_ranges.h).
std::uint64_t rollout_seed(std::uint64_t seed, std::int64_t task, std::int64_t episode);

// Trains `policy` (its parameters as given: fresh, or a BC run's) on `data`'s tasks, whose envs `make_env` builds, or
// resumes from run_dir/last.ckpt; then loads best.ckpt into `policy`. At most `max_iterations` iterations in this
// call when >= 0 (tests; a later call resumes). A non-finite loss throws std::runtime_error naming the iteration and
// the term, last.ckpt left at the last good iteration.
GailSummary train_gail(core::Policy& policy, const core::DemoDataset& data, const core::EnvFactory& make_env,
                       const GailConfig& config, std::uint64_t seed, const std::string& run_dir, std::ostream* log,
                       std::int64_t max_iterations = -1);

}  // namespace maps::adversarial
