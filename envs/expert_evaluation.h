#pragma once

#include <cstdint>
#include <vector>

#include "envs/env.h"
#include "envs/task_expert.h"

// An expert's episodes from given seeds, with the numbers every report of expert quality uses.
namespace maps::envs {

struct ExpertEpisodes {
  std::vector<double> returns;
  std::vector<bool> successes;            // success at some step
  std::vector<int> first_success_steps;   // -1 where never
  std::vector<double> failure_fractions;  // share of steps in the env's failure state (HalfCheetah: turned over)
  // Per episode, the return with Gym's control cost on the unclipped action (StepResult::unclipped_control_cost).
  std::vector<double> returns_unclipped_cost;

  double mean_return() const;
  double mean_return_unclipped_cost() const;
  double return_std() const;  // population
  int success_count() const;
  // Episodes that spent more than half their steps in the failure state (HalfCheetah: ran on its back).
  int failed_count() const;
};

// `episodes` episodes of the expert's mean action from seeds first_seed, first_seed + 1, ...
ExpertEpisodes run_expert(Env& env, const TaskExpert& expert, int episodes, std::uint64_t first_seed);

}  // namespace maps::envs
