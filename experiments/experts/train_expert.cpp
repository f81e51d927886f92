// `maps train-expert`: PPO (maps/rl) on one HalfCheetah task, with resume, an upright check and the export of an
// envs::ExpertPolicy.

#include "experiments/experts/train_expert.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <stdexcept>

#include "envs/expert_evaluation.h"
#include "envs/seed_ranges.h"
#include "envs/task_sets.h"
#include "experiments/process/host.h"
#include "io/output_files.h"
#include "maps/rl/ppo.h"
#include "maps/rl/upright.h"

namespace maps::experiments {
namespace {

// Evaluation episodes start from seeds in their own range (envs/seed_ranges.h), apart from the demonstrations'.
constexpr std::uint64_t kEvalSeedBase = envs::kEvalSeedBegin;
// An episode counts as flipped when the torso spent more than half its steps turned over (cos(pitch) < 0).
constexpr double kFlippedFraction = 0.5;  // as envs::ExpertEpisodes::failed_count

}  // namespace

int run_train_expert(const TrainExpertOptions& options) {
  if (options.abandon_flipped > 0 && options.end_at_pitch > 0.0 && options.end_at_pitch <= std::numbers::pi / 2)
    throw std::invalid_argument("--abandon-flipped watches for rollouts run turned over, which --end-at-pitch " +
                                std::to_string(options.end_at_pitch) +
                                " (<= pi/2) never lets happen; use one or the other");
  io::check_output_folder("--out", options.out);
  auto env = envs::make_env(options.task);
  auto eval_env = envs::make_env(options.task);
  rl::PPOConfig config;
  config.total_steps = options.steps;
  config.seed = options.seed;
  config.learning_rate = options.learning_rate;
  config.checkpoint_every = options.checkpoint_every;
  config.pitch_index = 1;  // HalfCheetah's rooty
  config.end_episode_at_pitch = options.end_at_pitch;
  std::printf("maps train-expert: task %s, %lld steps, seed %llu, out %s\n", options.task.c_str(),
              static_cast<long long>(options.steps), static_cast<unsigned long long>(options.seed),
              options.out.c_str());
  std::fflush(stdout);
  rl::PPOTrainer trainer(*env, config, options.out, &std::cout);
  if (!trainer.resume() && !options.init.empty()) trainer.warm_start_from(options.init);
  bool abandoned = false;
  if (options.abandon_flipped > 0) {
    trainer.set_iteration_callback([&](const rl::PPOIterationStats& stats) {
      const auto& h = trainer.history();
      if (stats.steps < options.abandon_flipped || h.size() < 5) return true;
      double flipped = 0.0;
      for (std::size_t i = h.size() - 5; i < h.size(); ++i) flipped += h[i].flipped_fraction / 5.0;
      if (flipped <= kFlippedFraction) return true;
      std::printf("abandoned at %lld steps: the last 5 rollouts spent %.0f%% of their steps turned over\n",
                  static_cast<long long>(stats.steps), 100.0 * flipped);
      abandoned = true;
      return false;
    });
  }
  const auto start = std::chrono::steady_clock::now();
  trainer.train();
  const double seconds = seconds_since(start);

  // The expert is judged as it will be used: the exported float64 policy (envs::ExpertPolicy), not the float32
  // actor. HalfCheetah is chaotic enough that the two drift apart within an episode, and their scores can differ
  // by a few percent (measured: up to 15% on 20 episodes, when one of them turns over).
  envs::ExpertPolicy expert = rl::export_expert(trainer.model(), trainer.observation_stats(), options.task);
  const envs::ExpertEpisodes episodes =
      envs::run_expert(*eval_env, envs::task_expert_from_policy(expert), options.eval_episodes, kEvalSeedBase);
  const int flipped = episodes.failed_count();
  double flipped_steps = 0.0;
  for (double f : episodes.failure_fractions) flipped_steps += f / static_cast<double>(options.eval_episodes);
  std::printf(
      "evaluation of the exported expert: %d deterministic episodes (seeds %llu..), return %.1f +- %.1f, %d flipped "
      "episodes (%.1f%% of steps turned over); training took %.0f s this run\n",
      options.eval_episodes, static_cast<unsigned long long>(kEvalSeedBase), episodes.mean_return(),
      episodes.return_std(), flipped, 100.0 * flipped_steps, seconds);

  expert.metadata_json = nlohmann::json{
      {"task", options.task},
      {"algorithm", "PPO (maps/rl)"},
      {"steps", trainer.steps_done()},
      {"seed", options.seed},
      {"learning_rate", options.learning_rate},
      {"warm_start", options.init},
      {"end_at_pitch", options.end_at_pitch},
      {"abandoned_as_flipped", abandoned},
      {"eval_episodes", options.eval_episodes},
      {"eval_seed_base", kEvalSeedBase},
      {"eval_of", "exported float64 expert"},
      {"eval_return_mean", episodes.mean_return()},
      {"eval_return_std", episodes.return_std()},
      {"flipped_episodes", flipped},
      {"flipped_step_fraction",
       flipped_steps}}.dump();
  const std::string path = (std::filesystem::path(options.out) / "expert.json").string();
  expert.save(path);
  std::printf("wrote %s%s\n", path.c_str(), flipped > 0 || abandoned ? " (WARNING: the expert ran on its back)" : "");
  return flipped > 0 || abandoned ? 3 : 0;
}

}  // namespace maps::experiments
