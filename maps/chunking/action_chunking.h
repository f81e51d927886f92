#pragma once

// How a policy that predicts action chunks is run (issue 46, item 2): how many actions a query predicts, how the
// predicted chunks become the action of each step, and whether the policy also reads the state before the current
// one. The evaluator keeps one ChunkExecutor per running episode.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "maps/chunking/temporal_ensemble.h"

namespace maps::chunking {

struct ActionChunking {
  // H: the actions one query predicts, the current step's and the H - 1 after it (1: one action per step, as
  // every method before chunking).
  std::int64_t horizon = 1;
  // "ensemble": query every step and average every chunk covering the step (ACT's temporal ensemble);
  // "open_loop": execute the first `execute` actions of a chunk, then query again (Diffusion Policy's receding
  // horizon; ACT without --temporal_agg is execute = H).
  std::string execution = "ensemble";
  std::int64_t execute = 1;      // open_loop: actions taken from each chunk, 1..H
  double ensemble_decay = 0.01;  // ensemble: ACT's m in the weights exp(-m i), i = 0 the oldest chunk
  // The policy conditions on the previous state too (Diffusion Policy's n_obs_steps = 2); the evaluator then
  // hands it the episode's previous observation (the first one itself at t = 0, as the demonstrations pair it).
  bool previous_observation = false;

  bool chunked() const { return horizon > 1; }
  bool operator==(const ActionChunking&) const = default;
};

// {"ensemble", "open_loop"}.
const std::vector<std::string>& execution_names();
// Throws std::invalid_argument naming `key` (the config section, e.g. "chunking") and what is wrong: horizon < 1
// or above 1000, an unknown execution, execute outside [1, horizon], a negative or non-finite decay.
void check_action_chunking(const ActionChunking& chunking, const std::string& key);

// One episode's execution of predicted chunks.
class ChunkExecutor {
 public:
  ChunkExecutor(const ActionChunking& chunking, std::int64_t action_size);
  // Whether the policy must be queried at this step before action() (every step with "ensemble").
  bool needs_chunk() const;
  // The chunk predicted at this step: H * action_size values, time-major (the step's action first).
  void add(const Eigen::Ref<const Eigen::VectorXd>& chunk);
  // The action of this step; advances to the next step.
  Eigen::VectorXd action();

 private:
  ActionChunking chunking_;
  std::int64_t action_size_;
  std::int64_t step_ = 0;
  TemporalEnsemble ensemble_;
  OpenLoop open_loop_;
};

}  // namespace maps::chunking
