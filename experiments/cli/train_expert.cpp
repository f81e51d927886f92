// `maps train-expert`: a HalfCheetah expert trained with PPO.

#include "experiments/experts/train_expert.h"

#include <memory>

#include "experiments/cli/command.h"
#include "experiments/cli/options.h"

namespace maps::experiments::cli {

void add_train_expert(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<TrainExpertOptions>();
  CLI::App* command = tool.add_subcommand(
      "train-expert", "Train a HalfCheetah expert with PPO, resuming from DIR's checkpoint; writes DIR/expert.json");
  command->add_option("--task", options->task, "Task name, e.g. gravity/0.5")->required();
  command->add_option("--out", options->out, "Run folder (checkpoint, expert.json)")->required();
  add_integer(command, "--steps", options->steps, 1, 1'000'000'000'000, "Total env steps");
  add_seed(command, options->seed, "Seed");
  add_positive(command, "--checkpoint-every", options->checkpoint_every, "Iterations between checkpoints");
  add_positive(command, "--eval-episodes", options->eval_episodes, "Deterministic episodes at the end");
  add_positive(command, "--lr", options->learning_rate, "Adam's initial learning rate (annealed to 0)");
  command->add_option("--init", options->init, "Warm start from another run's checkpoint.ckpt (when DIR has none)");
  add_integer(command, "--abandon-flipped", options->abandon_flipped, 0, 1'000'000'000'000,
              "Past this many steps, stop (exit 3) once the last 5 rollouts ran on the back; 0: never");
  command
      ->add_option("--end-at-pitch", options->end_at_pitch,
                   "End a training episode (terminated, not bootstrapped) once the torso's |pitch| exceeds this many "
                   "radians (1.5708: turned over); 0: never")
      ->check(number_in(0.0, 3.14159265358979))
      ->capture_default_str();
  commands.push_back({command, [options] { return run_train_expert(*options); }});
}

}  // namespace maps::experiments::cli
