// `maps suite calibrate`: the cost table measured from short runs of every method (each choice of its cost option
// apart) on every set.

#include "experiments/suite/calibrate.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "autograd/matmul_precision.h"
#include "envs/task_sets.h"
#include "experiments/process/cpu_model.h"
#include "experiments/process/host.h"
#include "experiments/run/run_folder.h"
#include "experiments/suite/cell.h"
#include "experiments/suite/costs.h"
#include "experiments/suite/demo_files.h"
#include "experiments/suite/folder.h"
#include "io/config_schema.h"
#include "maps/adversarial/gail_config.h"
#include "maps/policies/policy_registry.h"
#include "maps/training/run_config.h"
#include "maps/training/run_config_fields.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// One timed variant of a method: its cost table key ("maps", "diffusion_policy/mlp") and its cell.
struct TimedCell {
  std::string key;
  SuiteCell cell;
};

// Every variant of the suite's cells the table prices apart: one per choice of the method's cost option.
std::vector<TimedCell> timed_cells(const Suite& suite) {
  std::vector<TimedCell> timed;
  for (const auto& cell : suite.cells) {
    const core::PolicyMethod& method = core::policy_method(cell.method);
    if (method.cost_option.empty()) {
      timed.push_back({cell.method, cell});
      continue;
    }
    const auto option = std::find_if(method.options.begin(), method.options.end(),
                                     [&](const io::Field& f) { return f.key == method.cost_option; });
    if (option == method.options.end() || option->choices.empty())
      throw std::logic_error("method " + method.name + ": cost_option '" + method.cost_option +
                             "' is not one of its choice options");
    for (const auto& choice : option->choices) {
      SuiteCell variant = cell;
      variant.request[cell.method][method.cost_option] = choice;
      variant.name = cell.set + "/" + cell.method + "-" + choice + "_d" + std::to_string(cell.demos) + "_s" +
                     std::to_string(cell.seed);
      timed.push_back({cost_key(cell.method, choice), variant});
    }
  }
  return timed;
}

// Why a method cannot train by GAIL ("" when it can): the run config's own refusal.
std::string gail_refusal(const nlohmann::json& request) {
  try {
    core::parse_run_config(request);
    return "";
  } catch (const std::exception& e) {
    return e.what();
  }
}

}  // namespace

int run_suite_calibrate(const SuiteCalibrateOptions& options) {
  const std::string out = options.out.empty() ? default_costs_path().string() : options.out;
  // The per-set settings of the timed suite (by default the paper's scale: batch, selector weights, MAML query) at a
  // short budget.
  const std::string suite_path =
      options.suite.empty() ? (default_costs_path().parent_path() / "paper.json").string() : options.suite;
  const Suite base = load_suite(suite_path);
  Json calibrated_methods = Json::array();
  for (const auto& name : options.methods.empty() ? core::policy_method_names() : options.methods) {
    core::policy_method(name);  // an unknown name: the error lists the known ones
    calibrated_methods.push_back(name);
  }
  const std::string cpu = cpu_model(), measured = utc_now();
  std::vector<std::string> set_names;
  for (const auto& name : options.sets.empty() ? envs::task_set_names() : options.sets)
    if (!options.sets.empty() || base.sets.count(name)) set_names.push_back(name);
  for (const auto& name : set_names)
    if (!base.sets.count(name)) throw std::invalid_argument("--sets: '" + name + "' is not a set of " + suite_path);
  // The table this run merges into, checked before anything is timed.
  Json table = Json::object();
  if (fs::exists(out)) {
    table = read_json_file(out);
    if (!table.is_object() || (table.contains("sets") && !table["sets"].is_object()))
      throw std::runtime_error(out +
                               ": not a cost table (expected an object with an object \"sets\"); move it away "
                               "or name another --out");
  }
  Json sets = Json::object();
  const bool bf16 = ag::matmul_precision_refusal(ag::MatmulPrecision::bf16).empty();
  if (!bf16)
    std::printf(
        "calibrate: this CPU has no AVX512-BF16: float32 steps only (a plan of bf16 cells needs a table "
        "calibrated on a CPU with it)\n");
  for (const auto& set_name : set_names) {
    Json config = base.source;
    config["grids"] = Json::array({{{"name", "calibrate"},
                                    {"sets", {set_name}},
                                    {"methods", calibrated_methods},
                                    {"demos", {base.sets.at(set_name).demos.front()}},
                                    {"seeds", {0}}}});
    config["defaults"] = merge_json(config.value("defaults", Json::object()),
                                    {{"train",
                                      {{"steps", options.steps},
                                       {"validate_every", std::max(1, options.steps / 2)},
                                       {"checkpoint_every", options.steps}}},
                                     {"eval", {{"episodes", options.episodes}, {"threads", 1}}}});
    const Suite suite = parse_suite(config, "calibration of " + set_name);
    std::vector<const SuiteCell*> cells;
    for (const auto& cell : suite.cells) cells.push_back(&cell);
    const auto collect_start = std::chrono::steady_clock::now();
    const bool had_file = fs::exists(suite.sets.at(set_name).demo_file);
    ensure_demo_files(suite, cells, 1);
    Json entry{{"methods", Json::object()}};
    // A plan prices collecting the paper's demo files: another suite's (fewer demonstrations) would understate it.
    if (!had_file && options.suite.empty()) entry["collect_seconds"] = seconds_since(collect_start);
    const fs::path work = fs::path(options.work) / set_name;
    for (const char* suffix : {"", "_bf16", "_gail"}) fs::remove_all(fs::path(options.work) / (set_name + suffix));
    // A training step alone: train.json's time less its validations and checkpoint writes, over the steps.
    const auto step_seconds_of = [&options](const Json& train) {
      return (train["seconds_this_process"].get<double>() - train.value("validation_seconds", 0.0) -
              train.value("checkpoint_seconds", 0.0)) /
             options.steps;
    };
    for (const auto& [key, cell] : timed_cells(suite)) {
      const CellOutcome outcome = run_cell(work, cell, 1);
      if (outcome.status != CellOutcome::Status::kFinished)
        throw std::runtime_error("calibration cell " + cell.name + " did not finish: " + outcome.error);
      const Json& result = outcome.result;
      const Json& train = result["train"];
      const double train_seconds = train["seconds_this_process"].get<double>();
      const double eval_seconds = result["eval"]["seconds"].get<double>();
      const double tasks = static_cast<double>(result["eval"]["tasks"].size());
      // Validation and checkpoint writes timed apart (train.json), so a plan counts them at its own cells'
      // validate_every and checkpoint_every rather than at this run's.
      const double validation_seconds = train.value("validation_seconds", 0.0);
      const double checkpoint_seconds = train.value("checkpoint_seconds", 0.0);
      const double validations = std::max(1.0, train.value("validations", 1.0));
      const double writes = std::max(1.0, train.value("checkpoints_written", 1.0));
      Json method{{"step_seconds", step_seconds_of(train)},
                  {"validation_seconds", validation_seconds / validations},
                  {"checkpoint_seconds", checkpoint_seconds / writes},
                  {"states_per_task", cell.request["train"]["states_per_task"]},
                  {"validation_states_per_task", cell.request["train"]["validation_states_per_task"]},
                  {"modules", cell.request["maps"]["modules"]},
                  {"query_per_task", cell.request["maml"]["query_per_task"]},
                  {"episode_seconds", eval_seconds / (options.episodes * tasks)},
                  {"overhead_seconds", std::max(0.0, outcome.seconds - train_seconds - eval_seconds)},
                  {"cpu", cpu},
                  {"measured", measured}};
      const core::PolicyMethod& registered = core::policy_method(cell.method);
      if (registered.evaluation_work)
        method["evaluation_work"] = registered.evaluation_work(cell.request.value(cell.method, Json::object()));
      std::printf(
          "calibrate: %s: %.2f ms per step, %.1f ms per validation, %.1f ms per checkpoint, %.3f s per "
          "episode, %.1f s overhead\n",
          cell.name.c_str(), 1e3 * method["step_seconds"].get<double>(),
          1e3 * method["validation_seconds"].get<double>(), 1e3 * method["checkpoint_seconds"].get<double>(),
          method["episode_seconds"].get<double>(), method["overhead_seconds"].get<double>());
      std::fflush(stdout);
      // The same cell with bfloat16 products (train.precision "bf16"), where the CPU has them: its steps alone
      // differ (validation and evaluation run float32).
      if (bf16) {
        SuiteCell bf16_cell = cell;
        bf16_cell.request["train"]["precision"] = "bf16";
        const CellOutcome bf16_outcome = run_cell(fs::path(options.work) / (set_name + "_bf16"), bf16_cell, 1);
        if (bf16_outcome.status != CellOutcome::Status::kFinished)
          throw std::runtime_error("calibration cell " + cell.name + " (bf16) did not finish: " + bf16_outcome.error);
        method["step_seconds_bf16"] = step_seconds_of(bf16_outcome.result["train"]);
        std::printf("calibrate: %s: %.2f ms per step in bf16\n", cell.name.c_str(),
                    1e3 * method["step_seconds_bf16"].get<double>());
        std::fflush(stdout);
      }
      // The same method trained by GAIL, where asked and where the method trains by GAIL (not MAML's inner loop,
      // not a policy of action chunks): its cost per env step (all tasks) with the warm-up off, and one
      // discriminator step's, for the warm-up's extra ones.
      if (options.gail_env_steps > 0) {
        SuiteCell gail_cell = cell;
        gail_cell.request["imitation"] = "gail";
        gail_cell.request["gail"] = {{"env_steps_per_task", options.gail_env_steps},
                                     {"discriminator_warmup_iterations", 0}};
        // The timed suite's BC-only training keys (refused under GAIL) at their defaults: only the method's own
        // refusal (MAML's inner loop, a policy of chunks) skips it.
        for (const core::RunConfigField& field : core::run_config_fields())
          for (const char* key : {"train.keep_every", "train.optimizer", "train.precision", "train.freeze",
                                  "train.lr_scale", "train.ema_power", "train.ema_max_decay"})
            if (field.spec.key == key) gail_cell.request[io::key_pointer(key)] = field.spec.default_value;
        if (const std::string why = gail_refusal(gail_cell.request); !why.empty()) {
          std::printf("calibrate: %s: no GAIL cost (it does not train by GAIL: %s)\n", cell.name.c_str(), why.c_str());
          std::fflush(stdout);
        } else {
          const CellOutcome gail_outcome = run_cell(fs::path(options.work) / (set_name + "_gail"), gail_cell, 1);
          if (gail_outcome.status != CellOutcome::Status::kFinished)
            throw std::runtime_error("calibration cell " + cell.name + " (GAIL) did not finish: " + gail_outcome.error);
          const Json& gail_train = gail_outcome.result["train"];
          const double env_steps = gail_train["env_steps_per_task"].get<double>() * tasks;
          const double updates =
              std::max(1.0, gail_train["iterations"].get<double>() * adversarial::GailConfig().discriminator_updates);
          method["gail_env_step_seconds"] = gail_train["seconds_this_process"].get<double>() / env_steps;
          method["gail_discriminator_update_seconds"] = gail_train["discriminator_seconds"].get<double>() / updates;
          method["gail_policy_env_step_seconds"] =
              (gail_train["rollout_policy_seconds"].get<double>() + gail_train["ppo_seconds"].get<double>()) /
              env_steps;
          std::printf("calibrate: %s: %.1f us per env step by GAIL\n", cell.name.c_str(),
                      1e6 * method["gail_env_step_seconds"].get<double>());
          std::fflush(stdout);
        }
      }
      entry["methods"][key] = method;
    }
    sets[set_name] = entry;
  }
  // Methods and sets not re-measured keep their old entries (collect times are kept when the file existed); entries
  // of an older table that name no CPU get the table's, before the table's own CPU becomes this run's.
  if (table.contains("sets"))
    for (auto& [name, old] : table["sets"].items())
      if (old.is_object() && old.contains("methods") && old["methods"].is_object())
        for (auto& [key, method] : old["methods"].items())
          if (method.is_object() && !method.contains("cpu")) {
            method["cpu"] = recorded_cpu(table);
            if (table.contains("measured")) method["measured"] = table["measured"];
          }
  for (auto& [name, entry] : sets.items()) {
    Json merged = table.contains("sets") && table["sets"].contains(name) && table["sets"][name].is_object()
                      ? table["sets"][name]
                      : Json::object();
    if (!merged.contains("methods") || !merged["methods"].is_object()) merged["methods"] = Json::object();
    for (auto& [key, method] : entry["methods"].items()) merged["methods"][key] = method;
    if (entry.contains("collect_seconds")) merged["collect_seconds"] = entry["collect_seconds"];
    if (!merged.contains("collect_seconds")) merged["collect_seconds"] = 0.0;
    table["sets"][name] = merged;
  }
  table["cpu"] = cpu;
  table["measured"] = measured;
  std::string command =
      "maps suite calibrate --steps " + std::to_string(options.steps) + " --episodes " +
      std::to_string(options.episodes) +
      (options.gail_env_steps > 0 ? " --gail-env-steps " + std::to_string(options.gail_env_steps) : "");
  if (!options.suite.empty()) command += " --suite " + options.suite;
  if (!options.methods.empty()) {
    command += " --methods";
    for (const auto& name : options.methods) command += " " + name;
  }
  if (!options.sets.empty()) {
    command += " --sets";
    for (const auto& name : options.sets) command += " " + name;
  }
  table["command"] = command;
  table["note"] =
      "one thread per cell, one cell at a time; step_seconds is a training step alone, validation_seconds one "
      "scoring of the validation states, checkpoint_seconds one checkpoint written; step_seconds_bf16 a step with "
      "train.precision bf16 (CPUs with AVX512-BF16); gail_env_step_seconds an env step of a GAIL run (all its parts, "
      "at the default gail settings, warm-up off), gail_policy_env_step_seconds its policy's part (rollout calls and "
      "PPO, the part that grows with the policy's size) and gail_discriminator_update_seconds one discriminator step; "
      "evaluation_work an evaluation step's policy calls relative to one (the method's own measure); a key "
      "method/choice prices one choice of the method's cost option (diffusion_policy/mlp: the MLP denoiser); cpu and "
      "measured say where and when each entry was timed, command the last calibration's";
  write_json_file(out, table);
  std::printf("calibrate: wrote %s\n", out.c_str());
  return 0;
}

}  // namespace maps::experiments
