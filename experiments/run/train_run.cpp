// `maps train`: one run of one method.

#include "experiments/run/train_run.h"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>

#include "autograd/matmul_precision.h"
#include "envs/task_sets.h"
#include "experiments/process/command_line.h"
#include "experiments/process/cpu_model.h"
#include "experiments/process/plugins.h"
#include "experiments/process/usage_error.h"
#include "experiments/run/config_overrides.h"
#include "experiments/run/provenance.h"
#include "experiments/run/run_folder.h"
#include "experiments/run/tee_stream.h"
#include "io/output_files.h"
#include "maps/adversarial/gail_state.h"
#include "maps/adversarial/gail_trainer.h"
#include "maps/training/init_from_run.h"
#include "maps/training/trainer.h"

namespace maps::experiments {
namespace {

// The keys whose values differ between two resolved configs, as dotted paths ("train.steps", "data.task_demos"):
// JSON pointers unescaped (~1 is '/', ~0 is '~'), a list named by its key rather than by its elements.
std::string differing_keys(const nlohmann::json& a, const nlohmann::json& b) {
  std::vector<std::string> keys;
  for (const nlohmann::json& change : nlohmann::json::diff(a, b)) {
    const std::string pointer = change.at("path").get<std::string>();
    std::string path;
    const nlohmann::json* in_a = &a;
    for (std::size_t at = 1; at <= pointer.size();) {
      const std::size_t next = std::min(pointer.find('/', at), pointer.size());
      std::string token = pointer.substr(at, next - at);
      for (std::size_t i = 0; (i = token.find('~', i)) != std::string::npos; ++i)
        token.replace(i, 2, i + 1 < token.size() && token[i + 1] == '1' ? "/" : "~");
      if (in_a == nullptr || !in_a->is_object()) break;  // an array's element, or a key only in b: named by its parent
      path += (path.empty() ? "" : ".") + token;
      in_a = in_a->contains(token) ? &in_a->at(token) : nullptr;
      at = next + 1;
    }
    if (std::find(keys.begin(), keys.end(), path) == keys.end()) keys.push_back(path);
  }
  std::string joined;
  for (const auto& key : keys) joined += (joined.empty() ? "" : ", ") + key;
  return joined;
}

// What the folder's last.ckpt has done: BC steps, or GAIL iterations.
std::int64_t progress_of(const core::RunConfig& config, const std::string& out) {
  if (config.imitation == "gail")
    return adversarial::gail_iterations_done((std::filesystem::path(out) / run_files::kLastCheckpoint).string());
  return core::trained_steps(out);
}

// Trains by GAIL and writes train.json; returns its summary line.
std::string train_adversarially(const core::RunConfig& config, core::Policy& policy, const core::DemoDataset& data,
                                const std::string& out, std::ostream& log, const nlohmann::json& common) {
  const adversarial::GailConfig gail = core::gail_config_of(config);
  const core::EnvFactory make_env = [](const std::string& task) { return envs::make_env(task); };
  const adversarial::GailSummary summary =
      adversarial::train_gail(policy, data, make_env, gail, config.seed, out, &log);
  nlohmann::json record = common;
  record.update({{"imitation", "gail"},
                 {"steps", summary.iterations},
                 {"iterations", summary.iterations},
                 {"env_steps_per_task", summary.env_steps_per_task},
                 {"best_step", summary.best_iteration},
                 {"best_validation_bc", summary.best_validation_loss},
                 {"seconds_this_process", summary.seconds},
                 {"env_steps_this_process", summary.env_steps_this_process},
                 {"physics_seconds", summary.physics_seconds},
                 {"rollout_policy_seconds", summary.rollout_policy_seconds},
                 {"discriminator_seconds", summary.discriminator_seconds},
                 {"ppo_seconds", summary.ppo_seconds},
                 {"other_seconds", summary.other_seconds},
                 {"resumed", summary.resumed}});
  write_json_file((std::filesystem::path(out) / run_files::kTrainSummary).string(), record);
  return "done: GAIL, " + std::to_string(summary.iterations) + " iterations, " +
         std::to_string(summary.env_steps_per_task) + " env steps per task; best.ckpt from iteration " +
         std::to_string(summary.best_iteration) + " (validation BC " + std::to_string(summary.best_validation_loss) +
         "); " + out + "/best.ckpt";
}

}  // namespace

// What DIR already holds decides what this invocation does: start, resume, or extend (only train.steps differs).
// Anything else is refused, naming the keys that differ.
void check_existing_run(const std::string& out, const nlohmann::json& resolved, std::ostream& log) {
  const std::string config_path = (std::filesystem::path(out) / run_files::kConfig).string();
  if (!std::filesystem::exists(config_path)) return;
  // Compared after resolving both, so a folder written before a key existed (its default then implied) resumes.
  const nlohmann::json existing = core::to_json(read_run_config(config_path));
  if (existing == resolved) return;
  nlohmann::json existing_but_steps = existing, resolved_but_steps = resolved;
  existing_but_steps["train"].erase("steps");
  resolved_but_steps["train"].erase("steps");
  if (existing_but_steps != resolved_but_steps)
    throw std::runtime_error(out + " holds a run of another config (" + config_path + " differs in " +
                             differing_keys(existing, resolved) +
                             "); use a new folder, or delete it to start over (only train.steps may change, to "
                             "extend a run)");
  if (resolved.value("imitation", "bc") == "gail")
    throw std::runtime_error(out + " holds a GAIL run of another config (" + config_path + " differs in " +
                             differing_keys(existing, resolved) + "); use a new folder, or delete it to start over");
  const std::int64_t done = core::trained_steps(out), wanted = resolved["train"]["steps"].get<std::int64_t>();
  if (done > wanted)
    throw std::invalid_argument(out + " has trained " + std::to_string(done) + " steps, more than train.steps " +
                                std::to_string(wanted) + ": a run can be extended, not shortened");
  log << "maps train: " << out << " was configured for " << existing["train"]["steps"] << " steps; continuing to "
      << resolved["train"]["steps"] << std::endl;
}

int run_train(const TrainRunOptions& options) {
  nlohmann::json json = options.config ? *options.config : read_json_file(options.config_path);
  apply_overrides(json, options.overrides);
  const std::string where = (options.config ? options.config_path : "--config '" + options.config_path + "'") +
                            (options.overrides.empty() ? "" : " with its --set overrides");
  // Before the rest is read: the config may name the plugins' losses and methods. Their paths become absolute, as
  // the run folder's config.json records them.
  json = load_config_plugins(std::move(json), options.config ? "." : folder_of(options.config_path), where);
  const core::RunConfig config = parse_run_config_from(json, where);
  const nlohmann::json resolved = core::to_json(config);
  if (options.print_config) {
    std::cout << resolved.dump(2) << std::endl;
    return 0;
  }
  if (options.out.empty()) throw UsageError("maps train: --out DIR is required (unless --print-config)");
  // Before the run folder is touched: a precision this CPU lacks is refused by name, not met as a crash.
  if (const std::string refusal =
          ag::matmul_precision_refusal(ag::parse_matmul_precision(config.train.precision), cpu_model());
      !refusal.empty())
    throw std::invalid_argument(where + ": train.precision \"" + config.train.precision + "\" " + refusal +
                                "; use \"float32\"");
  std::vector<std::string> writes = kTrainWrites;
  if (std::filesystem::is_directory(options.out))
    for (const auto& entry : std::filesystem::directory_iterator(options.out))
      if (const std::string name = entry.path().filename().string();
          name.starts_with("step_") && name.ends_with(".ckpt"))
        writes.push_back(name);
  io::check_output_files_in("--out", options.out, writes, kTrainAppends);
  const std::filesystem::path dir(options.out);
  std::ofstream log_file(dir / run_files::kTrainLog, std::ios::app);
  if (!log_file) throw std::runtime_error("cannot append to " + (dir / run_files::kTrainLog).string());
  TeeStream log(std::cout, log_file);
  log << "---- " << provenance_record()["started_utc"].get<std::string>() << "  " << command_line() << std::endl;
  try {
    check_existing_run(options.out, resolved, log);
    const core::DemoDataset data = load_run_dataset(config, options.out);
    append_provenance(options.out, provenance_record({{"subcommand", "train"},
                                                      {"config_file", options.config_path},
                                                      {"overrides", options.overrides},
                                                      {"start_step", progress_of(config, options.out)},
                                                      {"imitation", config.imitation},
                                                      {"steps", config.train.steps},
                                                      {"threads", options.threads},
                                                      {"matmul_precision", config.train.precision},
                                                      {"demo_file", config.data_file},
                                                      {"demo_file_sha256", sha256_of_file(config.data_file)}}));
    const core::PolicyShape shape{data.observation_size(), data.action_size(), data.num_tasks()};
    const auto policy = core::make_policy(config, shape);
    if (!config.init_run.empty() && progress_of(config, options.out) == 0) {
      const std::string source_dir = init_run_folder(config, options.out);
      try {
        const TrainedRun source = load_trained_run(source_dir, config.init_checkpoint);
        core::initialize_from(*policy, data.task_names(), *source.policy, source.data->task_names());
        log << "maps train: starting from " << source_dir << "/" << config.init_checkpoint << " (step "
            << source.best.value("step", -1) << ", tasks " << source.data->task_names().size() << ")" << std::endl;
      } catch (const std::exception& e) {
        throw std::invalid_argument("init.run " + source_dir + ": cannot start from it: " + e.what());
      }
    }
    // Written once the run can start, so that a refused start leaves no config behind that a corrected rerun into
    // the same folder would be compared with.
    write_json_file((dir / run_files::kConfig).string(), resolved);
    std::size_t fewest = SIZE_MAX, most = 0;
    for (const auto& seeds : data.training_demo_seeds())
      fewest = std::min(fewest, seeds.size()), most = std::max(most, seeds.size());
    log << "maps train: " << config.method << " on " << config.data_file << " (" << data.num_tasks() << " tasks, "
        << (fewest == most ? std::to_string(most) : std::to_string(fewest) + "-" + std::to_string(most))
        << " demos per task, subsample " << config.data.subsample << "), seed " << config.seed << ", "
        << (config.imitation == "gail"
                ? "GAIL, " + std::to_string(config.gail.env_steps_per_task) + " env steps per task"
                : std::to_string(config.train.steps) + " steps")
        << " -> " << options.out << std::endl;
    const double maps_parameters = core::maps_parameter_count(config, shape);
    log << "maps train: " << policy->parameter_count()
        << " parameters (MAPS under this config: " << static_cast<long long>(maps_parameters) << ")" << std::endl;
    ag::set_num_threads(options.threads);
    nlohmann::json seeds = nlohmann::json::object();
    for (int k = 0; k < data.num_tasks(); ++k) seeds[data.task_names()[k]] = data.training_demo_seeds()[k];
    if (config.imitation == "gail") {
      log << train_adversarially(config, *policy, data, options.out, log,
                                 {{"parameters", policy->parameter_count()},
                                  {"maps_parameters", maps_parameters},
                                  {"training_demo_seeds", seeds}})
          << std::endl;
      return 0;
    }
    core::TrainConfig train = config.train;
    train.validate_start = !config.init_run.empty();
    const core::TrainSummary summary = core::train_policy(*policy, data, train, options.out, &log);

    write_json_file((dir / run_files::kTrainSummary).string(), {{"steps", summary.steps_done},
                                                                {"best_step", summary.best_step},
                                                                {"best_validation_bc", summary.best_validation_loss},
                                                                {"seconds_this_process", summary.seconds},
                                                                {"validation_seconds", summary.validation_seconds},
                                                                {"validations", summary.validations},
                                                                {"checkpoint_seconds", summary.checkpoint_seconds},
                                                                {"checkpoints_written", summary.checkpoints_written},
                                                                {"resumed", summary.resumed},
                                                                {"parameters", policy->parameter_count()},
                                                                {"maps_parameters", maps_parameters},
                                                                {"training_demo_seeds", seeds}});
    log << "done: best validation BC " << summary.best_validation_loss << " at step " << summary.best_step << "; "
        << options.out << "/best.ckpt" << std::endl;
  } catch (const std::exception& e) {
    log_file << "maps: error: " << e.what() << std::endl;
    throw;
  }
  return 0;
}

}  // namespace maps::experiments
