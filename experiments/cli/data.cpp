// `maps data export|import`: demo files to and from D4RL, Minari and robomimic.

#include <memory>

#include "experiments/cli/command.h"
#include "experiments/interop/data_convert.h"

namespace maps::experiments::cli {
namespace {

CLI::Option* add_format(CLI::App* command, std::string& format) {
  return command->add_option("--format", format, "d4rl, minari or robomimic")
      ->required()
      ->check(CLI::IsMember({"d4rl", "minari", "robomimic"}));
}

}  // namespace

void add_data(CLI::App& tool, Commands& commands) {
  CLI::App* data = tool.add_subcommand("data", "Demo files to and from D4RL, Minari and robomimic (docs/interop.md)");
  data->require_subcommand(1);

  auto out = std::make_shared<DataConvertOptions>();
  CLI::App* export_command = data->add_subcommand("export", "Write a demo file in another tool's format");
  add_format(export_command, out->format);
  export_command->add_option("input", out->input, "Demo file (format 2)")->required()->check(CLI::ExistingFile);
  export_command->add_option("--out", out->out, "The file to write (Minari: the dataset folder)")->required();
  export_command->add_option("--dataset-id", out->dataset_id, "Minari's dataset id (default maps/<set>/expert-v0)");
  commands.push_back({export_command, [out] { return run_data_export(*out); }});

  auto in = std::make_shared<DataConvertOptions>();
  CLI::App* import_command = data->add_subcommand("import", "Make a demo file from another tool's dataset");
  add_format(import_command, in->format);
  import_command->add_option("input", in->input, "The dataset (a file; Minari: its dataset folder)")
      ->required()
      ->check(CLI::ExistingPath);
  import_command->add_option("--out", in->out, "Demo file to write")->required();
  import_command->add_flag("--force", in->force, "Replace --out if it exists");
  import_command->add_option("--task-set", in->task_set,
                             "Set name for a dataset made elsewhere (default: its file or dataset name)");
  import_command->add_option("--obs-keys", in->obs_keys,
                             "robomimic: observation keys, comma-separated, in column order (default: all, sorted)");
  commands.push_back({import_command, [in] { return run_data_import(*in); }});
}

}  // namespace maps::experiments::cli
