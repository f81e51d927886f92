#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "maps/adversarial/discriminator.h"
#include "maps/adversarial/gail_head.h"
#include "maps/policies/policy.h"
#include "maps/rl/running_mean_std.h"
#include "nn/optim/adam.h"

// GAIL's last.ckpt: the policy, the Gaussian head and critic, the discriminator, both Adam states and the reward
// normalisers as tensors ("policy.", "head.", "discriminator.", "adam.", "discriminator_adam.", "return_stats"
// [K, 3]: mean, variance, count of each task's discounted return), and the JSON record below with the two random
// streams. Read as untrusted input: every key checked, every tensor against the modules built from the run config.
namespace maps::adversarial {

inline constexpr const char* kGailStateFormat = "maps-gail 1";

struct GailState {
  std::int64_t iteration = 0;
  std::int64_t env_steps_per_task = 0;
  std::int64_t best_iteration = 0;  // 0: none yet
  double best_validation = INFINITY;
};

struct GailModules {
  core::Policy& policy;
  GaussianCriticHead& head;
  Discriminator& discriminator;
  optim::Adam& adam;
  optim::Adam& discriminator_adam;
  // Each task's reward normaliser; every episode ends inside its rollout, so only the statistics carry over.
  std::vector<rl::RewardScaler>& reward_scalers;
};

void save_gail_state(const std::string& path, const GailState& state, const GailModules& modules,
                     const std::mt19937_64& rng, const ag::Generator& noise);
// The record's state (untrusted text: every key checked), and its two random streams where asked; throws
// std::runtime_error naming `where`.
GailState read_gail_record(const std::string& text, const std::string& where, std::mt19937_64* rng = nullptr,
                           std::mt19937_64* noise = nullptr);
// The iterations a GAIL run's last.ckpt holds (0 when there is none).
std::int64_t gail_iterations_done(const std::string& last_checkpoint);
// Loads everything into `modules`, `rng` and `noise`; throws std::runtime_error naming the file and what is wrong.
GailState load_gail_state(const std::string& path, GailModules& modules, std::mt19937_64& rng, ag::Generator& noise);

}  // namespace maps::adversarial
