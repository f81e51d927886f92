#pragma once

#include <cstdint>
#include <string>

#include "envs/seed_ranges.h"

namespace maps::experiments {

// `maps expert-eval`: runs each task's expert (mean action) from evaluation seeds and prints per task the return,
// the success rate (success at any step) and the episodes spent mostly in the failure state (HalfCheetah: turned
// over). Tasks run in parallel.
struct ExpertEvalOptions {
  std::string task_set;  // one of task_set and task
  std::string task;
  int episodes = 20;
  std::uint64_t first_seed = envs::kEvalSeedBegin;
  int threads = 0;    // 0: one per core
  std::string out;    // optional: the table as a JSON file
  bool json = false;  // print the table as one JSON array on stdout (the text goes to stderr)
};

int run_expert_eval(const ExpertEvalOptions& options);

}  // namespace maps::experiments
