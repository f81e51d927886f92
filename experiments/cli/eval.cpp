// `maps eval`: a trained run evaluated on held-out initial states.

#include <memory>

#include "experiments/cli/command.h"
#include "experiments/cli/options.h"
#include "experiments/run/eval_run.h"

namespace maps::experiments::cli {

void add_eval(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<EvalRunOptions>();
  CLI::App* command = tool.add_subcommand("eval", "Evaluate a trained run on held-out initial states");
  command->add_option("--run", options->run, "Run folder written by maps train")
      ->required()
      ->check(CLI::ExistingDirectory);
  command->add_option("--episodes", options->episodes, "Episodes per task (default: the run config's)")
      ->check(positive());
  // No default shown: without the option the run config's count is used.
  command->add_option("--threads", options->threads, "Threads (0: one per core; default: the run config's)")
      ->check(thread_count());
  command->add_flag(
      "--checkpoints", options->checkpoints,
      "Also evaluate every kept step_<N>.ckpt (train.keep_every): the paper's best-over-checkpoints rule");
  auto* last = command->add_flag("--last", options->last,
                                 "Also evaluate the policy after the last training step (last.ckpt; with "
                                 "train.ema_power, its average of the weights): the final-checkpoint rule");
  command
      ->add_flag("--each-module", options->each_module,
                 "MAPS: score every task with the selector forced onto each module in turn, into eval_modules.json "
                 "(eval.json is left alone)")
      ->excludes("--checkpoints")
      ->excludes(last);
  commands.push_back({command, [options] { return run_eval(*options); }});
}

}  // namespace maps::experiments::cli
