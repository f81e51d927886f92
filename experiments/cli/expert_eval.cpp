// `maps expert-eval`: each task's expert scored from evaluation seeds.

#include "experiments/experts/expert_eval.h"

#include <memory>

#include "experiments/cli/command.h"
#include "experiments/cli/options.h"

namespace maps::experiments::cli {

void add_expert_eval(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<ExpertEvalOptions>();
  CLI::App* command = tool.add_subcommand(
      "expert-eval", "Score each task's expert (mean action) from evaluation seeds: return, success, turned over");
  CLI::Option* set = add_task_set(command, options->task_set);
  set->excludes(command->add_option("--task", options->task, "One task instead of a set"));
  add_positive(command, "--episodes", options->episodes, "Episodes per task");
  command->add_option("--first-seed", options->first_seed, "Reset seed of the first episode")
      ->check(seed_value())
      ->capture_default_str();
  add_threads(command, options->threads, "Tasks evaluated at once (0: one per core)");
  command->add_option("--out", options->out, "Also write the table to this JSON file");
  command->add_flag("--json", options->json, "Print the table as one JSON array (the text goes to stderr)");
  commands.push_back({command, [options] { return run_expert_eval(*options); }});
}

}  // namespace maps::experiments::cli
