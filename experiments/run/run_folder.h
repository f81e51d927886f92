#pragma once

#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "maps/data/demo_dataset.h"
#include "maps/training/run_config.h"
#include "maps/training/run_files.h"

// A run folder (maps train / maps eval): config.json (the resolved config), last.ckpt, best.ckpt, curve.csv,
// train.json (the training summary), eval.json (the evaluation).
namespace maps::experiments {

namespace run_files = core::run_files;

// The files of a run folder that `maps train` writes whole (through a temporary and a rename), and those it appends
// to; `maps eval` writes eval.json (eval_modules.json with --each-module); kept steps are step_<N>.ckpt.
inline const std::vector<std::string> kTrainWrites = {run_files::kConfig, run_files::kProvenance,
                                                      run_files::kLastCheckpoint, run_files::kBestCheckpoint,
                                                      run_files::kTrainSummary};
inline const std::vector<std::string> kTrainAppends = {run_files::kTrainLog, run_files::kCurve};

// Writes JSON atomically (io::write_file_atomically: a temporary in the same folder, then rename).
void write_json_file(const std::string& path, const nlohmann::json& json);
nlohmann::json read_json_file(const std::string& path);

// A run config file (a run folder's config.json, `maps train --config`), parsed and checked; an error names the file.
core::RunConfig read_run_config(const std::string& path);
// The same for a config given as JSON that came from `where` (a file and its --set overrides).
core::RunConfig parse_run_config_from(const nlohmann::json& json, const std::string& where);

// The run's demonstrations, as its config draws them (standardised as init.run's checkpoint says, if it names one).
core::DemoDataset load_run_dataset(const core::RunConfig& config, const std::string& run_dir);

// The folder init.run names for the run in `run_dir`: a relative init.run is relative to the run folder (a suite's
// transfer cell names its source as a sibling, "../<cell>"); empty when the config names none.
std::string init_run_folder(const core::RunConfig& config, const std::string& run_dir);

// A trained run ready to act: its config, its demonstrations, and its policy at `checkpoint` (a file of the run
// folder: best.ckpt, or step_<N>.ckpt) in evaluation mode,
// prepared for evaluation (MAML fine-tuned per task). Throws naming the folder when best.ckpt is missing, and when
// the demo file no longer gives the standardizer the policy was trained with. `data_file` (when not empty) replaces
// the config's data.file: a relative one names a file from the folder training ran in, which a caller elsewhere
// cannot see.
struct TrainedRun {
  core::RunConfig config;
  std::unique_ptr<core::DemoDataset> data;
  std::shared_ptr<core::Policy> policy;
  nlohmann::json best;  // the checkpoint's config: step, validation loss, standardizer
};
TrainedRun load_trained_run(const std::string& run, const std::string& checkpoint = run_files::kBestCheckpoint,
                            const std::string& data_file = "");

// The policy after the last training step of the run in folder `run`, read from last.ckpt (the trainer's resume
// state) and ready to act as load_trained_run's: with train.ema_power above 0 its average of the weights (what
// best.ckpt and the kept steps hold), else the trained weights. `trained` is the run as load_trained_run loaded it:
// last.ckpt must be of the same run (its best step best.ckpt's) and of a finished one (its step train.steps).
// Throws naming the file when last.ckpt is missing, is not a training state, does not fit the run's policy or
// disagrees with the run config on the average of the weights, and for a GAIL run (whose best.ckpt is its last
// iteration's policy already).
struct FinalPolicy {
  std::shared_ptr<core::Policy> policy;
  std::int64_t step = 0;
};
FinalPolicy load_final_policy(const std::string& run, const TrainedRun& trained);

}  // namespace maps::experiments
