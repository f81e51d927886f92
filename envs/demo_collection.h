#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "envs/demo_file.h"
#include "envs/env.h"
#include "envs/seed_ranges.h"
#include "envs/task_expert.h"

// Rolling an expert out into demonstrations of expert quality. The first `demos` episodes (seeds first_seed,
// first_seed + 1, ...) fix the expert's median return; an episode is discarded when it ends in the env's failure
// state (HalfCheetah: turned over), spends more than max_failure_fraction of its steps there, or returns less than
// min_return_fraction of that median, or (with require_success) never met the task's success test, and the next
// seed replaces it.
namespace maps::envs {

enum class DemoActions {
  kMean,    // the expert's deterministic (mean) action
  kSample,  // mean + exp(log_std) * N(0, I), as an RL expert's own rollouts act
};

// "mean" / "sample"; parse_demo_actions throws naming the accepted words.
std::string to_string(DemoActions actions);
DemoActions parse_demo_actions(const std::string& word);

struct DemoCollectionConfig {
  int demos = 35;  // kept demonstrations per task
  DemoActions actions = DemoActions::kMean;
  std::uint64_t first_seed = kDemoSeedBegin;
  double min_return_fraction = 0.8;
  double max_failure_fraction = 0.05;
  bool require_success = false;  // MT10: a demonstration must succeed at some step
  // Give up (an error naming the task and the reasons) after demos * max_attempts_factor episodes.
  int max_attempts_factor = 4;
  // Action noise of kSample: episode with reset seed s draws from a generator seeded by mixing s with this.
  std::uint64_t noise_seed = 0;
};

struct DiscardedEpisode {
  std::uint64_t seed = 0;
  double episode_return = 0.0;
  std::string reason;  // e.g. "ended turned over", "return 2310.4 < 0.8 x median 4620.9"
};

struct TaskDemonstrations {
  std::vector<Demonstration> demos;  // seeds ascending
  double median_return = 0.0;        // of the first `demos` episodes, the reference for the return test
  std::vector<DiscardedEpisode> discarded;
};

// Throws std::invalid_argument for a config out of range or an expert of another task, and std::runtime_error
// when too many episodes are discarded or a seed would reach kEvalSeedBegin.
TaskDemonstrations collect_task_demonstrations(Env& env, const TaskExpert& expert, const DemoCollectionConfig& config);

}  // namespace maps::envs
