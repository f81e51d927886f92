// `maps transfer`: a MAPS run taught a held-out task from a few demonstrations.

#include <memory>

#include "experiments/cli/command.h"
#include "experiments/cli/options.h"
#include "experiments/run/transfer_run.h"

namespace maps::experiments::cli {

void add_transfer(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<TransferOptions>();
  CLI::App* command = tool.add_subcommand(
      "transfer", "Teach a MAPS run trained without task T to do T from a few demonstrations, reusing its modules");
  command->add_option("--run", options->run, "A MAPS run folder trained without --task (data.holdout)")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--task", options->task, "The new task, e.g. gravity/0.5")->required();
  command->add_option("--demos", options->demos, "Training demonstrations of the new task")
      ->required()
      ->check(positive());
  command->add_option("--out", options->out, "Run folder to write (resumes)")->required();
  command->add_option("--freeze", options->freeze, "What stays as trained: modules, modules,head, head or none")
      ->capture_default_str();
  add_non_negative(command, "--module-lr-scale", options->module_lr_scale,
                   "With the modules trained (--freeze none or head): their learning rate's factor");
  command->add_option("--seed", options->seed, "Seed (default: the source run's)")->check(seed_value());
  command->add_option("--steps", options->steps, "Training steps (default: the source run's)")
      ->check(integer_in(1, 1'000'000'000'000));
  add_threads(command, options->threads, "Op threads (0: one per core)");
  commands.push_back({command, [options] {
                        options->threads = threads_or_cores(options->threads);
                        return run_transfer(*options);
                      }});
}

}  // namespace maps::experiments::cli
