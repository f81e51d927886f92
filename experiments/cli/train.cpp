// `maps train`: one method trained on a demo file as a run config says.

#include <memory>
#include <string>

#include "experiments/cli/command.h"
#include "experiments/cli/options.h"
#include "experiments/run/train_run.h"
#include "maps/policies/policy_registry.h"
#include "maps/selector/selector_loss.h"

namespace maps::experiments::cli {

void add_train(CLI::App& tool, Commands& commands) {
  auto options = std::make_shared<TrainRunOptions>();
  CLI::App* command = tool.add_subcommand("train", "Train one method on a demo file as a JSON config says");
  std::string method_lines = "Methods (config \"method\"; docs/configs.md, docs/zoo.md):";
  std::string not_by_gail, own_chunks;
  for (const auto& method : core::policy_methods()) {
    method_lines +=
        "\n  " + method.name + std::string(method.name.size() < 10 ? 10 - method.name.size() : 1, ' ') + method.summary;
    if (!method.not_trained_by_gail.empty()) not_by_gail += (not_by_gail.empty() ? "" : ", ") + method.name;
    if (method.own_chunking) own_chunks += (own_chunks.empty() ? "" : ", ") + method.name;
  }
  method_lines +=
      "\nSelector losses (config maps.selector_losses; docs/selector-losses.md): " + core::selector_loss_names() +
      "\nAction chunks (config chunking.*; docs/zoo.md): chunking.horizon actions a query, executed by ACT's ensemble "
      "or open loop; every method but " +
      own_chunks + " (chunks in its own section)" +
      "\nImitation objective (config imitation; docs/adversarial.md): bc (default) or gail (PPO on a "
      "discriminator's reward in the envs, gail.*; one action a step; every method but " +
      not_by_gail + ")";
  command->footer(method_lines);
  command->add_option("--config", options->config_path, "Run config (JSON; every key in docs/configs.md)")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out,
                      "Run folder (resumes a run of the same config; a finished one is extended when only "
                      "train.steps grew)");
  command->add_option("--set", options->overrides,
                      "Override a config key: --set train.steps=40000 --set maps.modules=5 (repeatable)");
  command->add_flag("--print-config", options->print_config,
                    "Print the resolved config (every key, defaults included) and exit without training");
  add_threads(command, options->threads, "Op threads for the training steps (0: one per core; docs/performance.md)");
  commands.push_back({command, [options] {
                        options->threads = threads_or_cores(options->threads);
                        return run_train(*options);
                      }});
}

}  // namespace maps::experiments::cli
