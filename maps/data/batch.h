#pragma once

#include <cstdint>
#include <vector>

#include "autograd/autograd.h"

namespace maps::core {

// A training batch of state-action pairs, observations already standardised.
struct Batch {
  ag::Tensor observations;           // [n, S]
  ag::Tensor previous_observations;  // [n, S]: the state before each one in its demonstration (itself at t = 0)
  ag::Tensor actions;                // [n, A]
  std::vector<std::int64_t> tasks;   // [n], task indices in [0, K)
  // > 0 when the batch is balanced: rows grouped by task, task 0's first, per_task rows each (n = K * per_task).
  std::int64_t per_task = 0;
  // Seeds the noise of a sampled BC loss (Policy::use_sampled_bc_loss); the trainer sets one per step.
  std::uint64_t noise_seed = 0;

  std::int64_t size() const { return static_cast<std::int64_t>(tasks.size()); }
};

}  // namespace maps::core
