// `maps transfer`: a new task from few demonstrations, reusing a trained MAPS run's modules.

#include "experiments/run/transfer_run.h"

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "envs/demo_file.h"
#include "experiments/process/usage_error.h"
#include "experiments/run/run_folder.h"
#include "experiments/run/train_run.h"
#include "io/output_files.h"
#include "maps/data/demo_dataset.h"
#include "maps/training/run_config.h"

namespace maps::experiments {
namespace {

std::vector<std::string> freeze_prefixes(const std::string& freeze) {
  if (freeze == "modules") return {"modules"};
  if (freeze == "modules,head" || freeze == "head,modules") return {"modules", "head"};
  if (freeze == "head") return {"head"};
  if (freeze == "none") return {};
  throw UsageError("--freeze: expected modules, modules,head, head or none, got '" + freeze + "'");
}

// The tasks a run trained on: its data.tasks (or all of the file's) less its data.holdout.
std::vector<std::string> trained_tasks(const core::RunConfig& config, const envs::DemoFile& file) {
  const std::vector<bool> keep = core::kept_tasks(file.task_names, file.task_set, config.data);
  std::vector<std::string> tasks;
  for (std::size_t k = 0; k < keep.size(); ++k)
    if (keep[k]) tasks.push_back(file.task_names[k]);
  return tasks;
}

}  // namespace

int run_transfer(const TransferOptions& options) {
  namespace fs = std::filesystem;
  const std::vector<std::string> freeze = freeze_prefixes(options.freeze);
  const bool modules_frozen = std::find(freeze.begin(), freeze.end(), "modules") != freeze.end();
  if (options.module_lr_scale != 1.0 && modules_frozen)
    throw UsageError("--module-lr-scale: the modules are frozen (--freeze " + options.freeze +
                     "); use --freeze none or --freeze head to fine-tune them");
  if (options.demos < 1) throw UsageError("--demos: expected at least 1 demonstration of the new task");
  const fs::path source_dir = fs::absolute(options.run);
  core::RunConfig source;
  try {
    source = read_run_config((source_dir / run_files::kConfig).string());
  } catch (const std::exception& e) {
    throw std::invalid_argument("--run " + options.run + ": " + e.what());
  }
  if (source.method != "maps")
    throw std::invalid_argument("--run " + options.run + " is a " + source.method +
                                " run; transfer reuses the modules of a MAPS run");
  if (!fs::exists(source_dir / run_files::kBestCheckpoint))
    throw std::invalid_argument("--run " + options.run + " has no best.ckpt: train it first");
  envs::DemoFile file;
  try {
    file = envs::read_demo_file(source.data_file);
  } catch (const std::exception& e) {
    throw std::invalid_argument("--run " + options.run +
                                ": its data.file (a relative path is read from the working "
                                "directory, as maps train read it): " +
                                e.what());
  }
  if (std::find(file.task_names.begin(), file.task_names.end(), options.task) == file.task_names.end()) {
    std::string known;
    for (const auto& task : file.task_names) known += (known.empty() ? "" : ", ") + task;
    throw std::invalid_argument("--task " + options.task + " is not a task of " + source.data_file + " (" + known +
                                ")");
  }
  const std::vector<std::string> seen = trained_tasks(source, file);
  if (std::find(seen.begin(), seen.end(), options.task) != seen.end())
    throw std::invalid_argument("--run " + options.run + " was trained on " + options.task +
                                ": transfer needs a run that never saw the task (train one with "
                                "--set 'data.holdout=[\"" +
                                options.task + "\"]')");

  nlohmann::json config;
  try {
    config =
        core::transfer_request(core::to_json(source), options.task, options.demos, freeze, options.module_lr_scale);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("--run " + options.run + ": " + e.what());
  }
  if (options.seed) config["seed"] = *options.seed;
  if (options.steps) config["train"]["steps"] = *options.steps;
  config["init"] = {{"run", source_dir.string()}, {"checkpoint", run_files::kBestCheckpoint}};
  const core::RunConfig parsed = core::parse_run_config(config);  // refuse here what maps train would

  std::error_code same_error;
  if (fs::exists(options.out) && fs::equivalent(options.out, source_dir, same_error))
    throw UsageError("--out " + options.out + " is the source run (--run): write the transfer to a folder of its own");
  io::check_output_folder("--out", options.out);
  // Refused before request.json is written, so that a refused transfer leaves the folder as it was.
  std::ostringstream ignored;
  check_existing_run(options.out, core::to_json(parsed), ignored);
  const std::string request = (fs::path(options.out) / run_files::kRequest).string();
  write_json_file(request, config);
  TrainRunOptions train;
  train.config_path = request;
  train.out = options.out;
  train.threads = options.threads;
  return run_train(train);
}

}  // namespace maps::experiments
