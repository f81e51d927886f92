#pragma once

#include <cstdint>

// Reset seeds by purpose, so an evaluation never starts from an initial state a demonstration started from.
// (PPO's training episodes use splitmix-mixed 63-bit seeds, maps::rl::training_episode_seed.)
namespace maps::envs {

// Demonstrations: seeds in [kDemoSeedBegin, kEvalSeedBegin).
inline constexpr std::uint64_t kDemoSeedBegin = 0;
// Evaluation of experts and of learned policies: seeds from kEvalSeedBegin upward.
inline constexpr std::uint64_t kEvalSeedBegin = 4'000'000'000ULL;

}  // namespace maps::envs
