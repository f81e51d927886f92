#include "experiments/run/run_folder.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "envs/demo_file.h"
#include "experiments/process/plugins.h"
#include "io/atomic_file.h"
#include "io/json_input.h"
#include "maps/training/checkpoint_record.h"
#include "maps/training/weight_average.h"
#include "nn/serialize.h"

namespace maps::experiments {

void write_json_file(const std::string& path, const nlohmann::json& json) {
  io::write_file_atomically(path, json.dump(2) + "\n");
}

nlohmann::json read_json_file(const std::string& path) { return io::read_json_file(path); }

core::RunConfig parse_run_config_from(const nlohmann::json& json, const std::string& where) {
  try {
    return core::parse_run_config(json);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(where + ": " + e.what());
  }
}

core::RunConfig read_run_config(const std::string& path) {
  const std::string where = "'" + path + "'";
  return parse_run_config_from(load_config_plugins(read_json_file(path), folder_of(path), where), where);
}

namespace {
// "+-10" or "no bound": a clamp as the errors name it.
std::string clip_text(double clip) {
  if (!(clip > 0.0)) return "no bound";
  std::ostringstream text;
  text << "+-" << clip;
  return text.str();
}
}  // namespace

std::string init_run_folder(const core::RunConfig& config, const std::string& run_dir) {
  if (config.init_run.empty()) return "";
  const std::filesystem::path folder(config.init_run);
  return (folder.is_absolute() ? folder : std::filesystem::path(run_dir) / folder).lexically_normal().string();
}

core::DemoDataset load_run_dataset(const core::RunConfig& config, const std::string& run_dir) {
  core::DemoDataset data(envs::read_demo_file(config.data_file), config.data);
  if (!config.init_run.empty()) {
    // A run started from another one standardises as that one did: its reused layers were trained on those inputs.
    const std::string path =
        (std::filesystem::path(init_run_folder(config, run_dir)) / config.init_checkpoint).string();
    if (!std::filesystem::exists(path))
      throw std::runtime_error("init.run: " + path + " does not exist (the run this one starts from)");
    const core::Standardizer standardizer =
        core::read_policy_record(nn::load_tensors(path).config, "init.run: checkpoint " + path, -1).standardizer;
    if (standardizer.clip != config.data.observation_clip)
      throw std::runtime_error("init.run: " + path + " was trained on inputs clamped to " +
                               clip_text(standardizer.clip) + "; this run's data.observation_clip says " +
                               clip_text(config.data.observation_clip) + " (the reused layers need the same inputs)");
    try {
      data.use_standardizer(standardizer);
    } catch (const std::invalid_argument& e) {
      throw std::runtime_error("init.run: " + path + " was trained on observations of another size than " +
                               config.data_file + "'s (" + e.what() + ")");
    }
  }
  return data;
}

TrainedRun load_trained_run(const std::string& run, const std::string& checkpoint, const std::string& data_file) {
  namespace fs = std::filesystem;
  const fs::path dir(run);
  TrainedRun loaded;
  loaded.config = read_run_config((dir / run_files::kConfig).string());
  if (!data_file.empty()) loaded.config.data_file = data_file;
  const std::string best_path = (dir / checkpoint).string();
  if (!fs::exists(best_path))
    throw std::runtime_error(run + " has no " + checkpoint + ": train it first (maps train --out " + run + ")");
  try {
    loaded.data = std::make_unique<core::DemoDataset>(load_run_dataset(loaded.config, run));
  } catch (const std::exception& e) {
    throw std::runtime_error(run + ": the demonstrations its config.json names: " + e.what());
  }
  const core::DemoDataset& data = *loaded.data;
  loaded.policy = core::make_policy(loaded.config, {data.observation_size(), data.action_size(), data.num_tasks()});
  const nn::Checkpoint saved = nn::load_tensors(best_path);
  // The trainer's resume state (last.ckpt) in the place of a policy checkpoint is named for what it is.
  if (core::record_format(saved.config) == core::kTrainingStateFormat)
    throw std::runtime_error(best_path +
                             " is a training state (as last.ckpt is: the policy with its optimiser), not a policy "
                             "checkpoint: use best.ckpt or a kept step_<N>.ckpt");
  // Sizes are compared after the tensors: a run evaluated on another set's demo file is named as such.
  const core::PolicyRecord record = core::read_policy_record(saved.config, "checkpoint " + best_path, -1);
  try {
    loaded.policy->load_state_dict(saved.tensors);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(run + " was not trained on demo file " + loaded.config.data_file + " (" + data.task_set() +
                             ": " + std::to_string(data.num_tasks()) + " tasks, observations " +
                             std::to_string(data.observation_size()) + ", actions " +
                             std::to_string(data.action_size()) + "): checkpoint " + best_path + ": " + e.what());
  }
  loaded.best = core::to_json(record);
  // The standardizer the policy was trained with; the demo file must still give the same one.
  const core::Standardizer& standardizer = data.standardizer();
  if (record.standardizer.size() != standardizer.size())
    throw std::runtime_error("checkpoint " + best_path + ": its standardizer is for observations of " +
                             std::to_string(record.standardizer.size()) + " entries, " + loaded.config.data_file +
                             "'s have " + std::to_string(standardizer.size()));
  if (((record.standardizer.mean - standardizer.mean).array().abs() > 1e-9).any() ||
      ((record.standardizer.std - standardizer.std).array().abs() > 1e-9).any())
    throw std::runtime_error(loaded.config.data_file + " is not the demo file " + run +
                             " was trained on (its observation statistics differ from those " + best_path +
                             " records)");
  if (record.standardizer.clip != standardizer.clip)
    throw std::runtime_error("checkpoint " + best_path + " was trained on inputs clamped to " +
                             clip_text(record.standardizer.clip) + ", " + run +
                             "'s config.json says data.observation_clip " + clip_text(standardizer.clip));
  loaded.policy->eval();
  loaded.policy->prepare_for_evaluation(data);
  return loaded;
}

FinalPolicy load_final_policy(const std::string& run, const TrainedRun& trained) {
  namespace fs = std::filesystem;
  const core::RunConfig& config = trained.config;
  const std::string path = (fs::path(run) / run_files::kLastCheckpoint).string();
  if (config.imitation != "bc")
    throw std::runtime_error(run + " was trained by " + config.imitation + ", whose " + run_files::kBestCheckpoint +
                             " is its last iteration's policy already (its " + run_files::kLastCheckpoint +
                             " is that trainer's own state)");
  if (!fs::exists(path))
    throw std::runtime_error(run + " has no " + run_files::kLastCheckpoint +
                             " (the trainer's state after its last step)");
  const nn::Checkpoint saved = nn::load_tensors(path);
  if (core::record_format(saved.config) != core::kTrainingStateFormat)
    throw std::runtime_error(path + " is not a training state (\"" + core::kTrainingStateFormat +
                             "\" record), as the trainer writes " + run_files::kLastCheckpoint);
  const core::TrainingState state = core::read_training_state(saved.config, "training checkpoint " + path);
  if (state.step != config.train.steps)
    throw std::runtime_error("training checkpoint " + path + " is at step " + std::to_string(state.step) + " of " +
                             std::to_string(config.train.steps) + ": training has not finished (maps train --out " +
                             run + " resumes it)");
  const std::int64_t best_step = trained.best.at("step").get<std::int64_t>();
  if (state.best_step != best_step)
    throw std::runtime_error("training checkpoint " + path + " records its best step as " +
                             std::to_string(state.best_step) + ", " + run_files::kBestCheckpoint + " is of step " +
                             std::to_string(best_step) + ": the two files are not of one run");
  const nn::NamedTensors averaged = nn::strip_prefix(saved.tensors, core::kTrainingStateAveragePrefix);
  const bool averages = config.train.ema_power > 0.0;
  core::check_average_agrees(path, state, !averaged.empty(), config.train.ema_power, config.train.ema_max_decay,
                             run + "'s config.json", core::AverageUse::kEvaluate);
  const core::DemoDataset& data = *trained.data;
  auto policy = core::make_policy(config, {data.observation_size(), data.action_size(), data.num_tasks()});
  try {
    policy->load_state_dict(nn::strip_prefix(saved.tensors, core::kTrainingStatePolicyPrefix));
    if (averages) {
      // The average replaces the trained parameters (buffers are not averaged), as best.ckpt and the kept steps hold
      // them; WeightAverage::load holds it to the policy's parameters, name by name, shape and dtype.
      core::WeightAverage average(policy->named_parameters(), config.train.ema_power, config.train.ema_max_decay);
      average.load(averaged, "training checkpoint " + path);
      average.apply();
    }
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("training checkpoint " + path + " does not fit " + run + "'s policy: " + e.what());
  }
  policy->eval();
  policy->prepare_for_evaluation(data);
  return {std::move(policy), state.step};
}

}  // namespace maps::experiments
