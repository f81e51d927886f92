// `maps collect`: a task set's committed experts rolled out into a demo file.

#include "experiments/experts/collect.h"

#include <memory>

#include "experiments/cli/command.h"
#include "experiments/cli/options.h"
#include "experiments/process/command_line.h"

namespace maps::experiments::cli {

void add_collect(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<CollectOptions>();
  CLI::App* command = tool.add_subcommand(
      "collect", "Roll a task set's committed experts out into demonstrations (HDF5, 70/30 train/valid per task)");
  // Before --set: CLI11 stores options in the order they are declared, so --set's check sees the plugins given.
  command->add_option("--plugin", options->plugins,
                      "A C++ or Python plugin whose task set --set names (repeatable; docs/extending.md)");
  add_task_set(command, options->task_set, &options->plugins)->required();
  add_positive(command, "--demos", options->demos, "Kept demonstrations per task");
  command->add_option("--out", options->out, "HDF5 file to write")->required();
  command->add_flag("--force", options->force, "Replace --out if it exists");
  command->add_option("--actions", options->actions, "Record the expert's mean action or a sampled one")
      ->check(CLI::IsMember({"mean", "sample"}))
      ->capture_default_str();
  command->add_option("--experts", options->experts_dir, "Folder of <set>/<task>.json experts (default: envs/experts)");
  command->add_option("--first-seed", options->first_seed, "First reset seed of the demonstrations")
      ->check(seed_value())
      ->capture_default_str();
  command
      ->add_option("--min-return-fraction", options->min_return_fraction,
                   "Discard an episode returning less than this fraction of the task's median (not for mt10)")
      ->check(number_in(0.0, 1.0))
      ->capture_default_str();
  command->add_option("--train-fraction", options->train_fraction, "Share of each task's demos in mask/train")
      ->check(number_in(0.0, 1.0))
      ->capture_default_str();
  command->add_option("--split-seed", options->split_seed, "Seed of the train/valid split")
      ->check(seed_value())
      ->capture_default_str();
  add_threads(command, options->threads, "Tasks rolled out at once (0: one per core)");
  commands.push_back({command, [options] {
                        options->command_line = command_line();
                        return run_collect(*options);
                      }});
}

}  // namespace maps::experiments::cli
