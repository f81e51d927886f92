#pragma once

#include <cstdint>
#include <string>

namespace maps::experiments {

// `maps train-expert`: trains a HalfCheetah expert with PPO (maps/rl), printing a progress line per iteration and
// resuming from the checkpoint in --out when there is one; at the end it evaluates the deterministic policy,
// checks that it ran upright, and writes DIR/expert.json (envs::ExpertPolicy).
struct TrainExpertOptions {
  std::string task;                  // e.g. "gravity/0.5"
  std::string out;                   // run folder: checkpoint.ckpt, expert.json
  std::int64_t steps = 5'000'000;    // total env steps (the learning rate reaches 0 there)
  std::uint64_t seed = 0;            // network init, action noise, training episode seeds
  int checkpoint_every = 10;         // iterations
  int eval_episodes = 20;            // deterministic episodes at the end
  double learning_rate = 3e-4;       // Adam's initial rate, annealed linearly to 0
  std::string init;                  // optional warm start: a checkpoint.ckpt of a run on another task
  std::int64_t abandon_flipped = 0;  // when > 0: past this many steps, stop if the last 5 rollouts ran flipped
  double end_at_pitch = 0.0;         // when > 0: end a training episode (terminated) once |pitch| exceeds it
};

// Returns 0 when the expert ran upright, 3 when it ran flipped or was abandoned as flipped (the expert is still
// written, with the verdict in its metadata).
int run_train_expert(const TrainExpertOptions& options);

}  // namespace maps::experiments
