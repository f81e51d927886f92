#pragma once

#include <cstdint>

// Reset seeds by purpose, so an evaluation never starts from an initial state a demonstration started from.
// (PPO's training episodes use splitmix-mixed 63-bit seeds, maps::rl::training_episode_seed.)
namespace maps::envs {

// Demonstrations: seeds in [kDemoSeedBegin, kEvalSeedBegin).
inline constexpr std::uint64_t kDemoSeedBegin = 0;
// Evaluation of experts and of learned policies: seeds from kEvalSeedBegin upward.
inline constexpr std::uint64_t kEvalSeedBegin = 4'000'000'000ULL;
// Episodes a learner collects for itself (GAIL's rollouts): seeds from 2^40 upward, above every evaluation seed (a run
// config allows at most 10^6 evaluation episodes per task).
inline constexpr std::uint64_t kRolloutSeedBegin = 1ULL << 40;

}  // namespace maps::envs
