// The cost table: measured costs and the estimate of a cell's CPU time.

#include "experiments/suite/costs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>

#include "envs/source_folders.h"
#include "envs/task_sets.h"
#include "experiments/process/cpu_model.h"
#include "experiments/run/run_folder.h"
#include "experiments/suite/folder.h"
#include "experiments/suite/run.h"
#include "maps/policies/policy_registry.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const long long s = std::llround(seconds);
  char text[64];
  if (s >= 3600)
    std::snprintf(text, sizeof(text), "%lldh%02lldm", s / 3600, (s % 3600) / 60);
  else if (s >= 60)
    std::snprintf(text, sizeof(text), "%lldm%02llds", s / 60, s % 60);
  else
    std::snprintf(text, sizeof(text), "%llds", s);
  return text;
}

std::string cost_key(const std::string& method, const std::string& choice) {
  return choice.empty() ? method : method + "/" + choice;
}

std::string recorded_cpu(const Json& holder) {
  return holder.contains("cpu") && holder["cpu"].is_string() ? holder["cpu"].get<std::string>()
                                                             : std::string("an unnamed CPU");
}

CostTable::CellCost CostTable::cell_cost(const SuiteCell& cell) const {
  const Json* entry = nullptr;
  // A transfer cell trains MAPS (for one task, from a trained run). A method whose cost depends on a choice
  // (Diffusion Policy's denoiser) is priced at its choice's entry, else at the method's. A method the table has not
  // measured (one added to the registry since) is estimated as MAPS, whose parameter budget the zoo's methods match by
  // default.
  const std::string base = cell.method == "transfer" ? "maps" : cell.method;
  const core::PolicyMethod* registered = nullptr;
  try {
    registered = &core::policy_method(base);
  } catch (const std::exception&) {
    // A name the suite's checks let through but this registry lacks: priced as any unmeasured method.
  }
  const Json empty = Json::object();
  const Json& own = cell.request.contains(base) && cell.request[base].is_object() ? cell.request[base] : empty;
  std::vector<std::string> candidates;
  if (registered && !registered->cost_option.empty() && own.contains(registered->cost_option) &&
      own[registered->cost_option].is_string())
    candidates.push_back(cost_key(base, own[registered->cost_option].get<std::string>()));
  candidates.push_back(base);
  candidates.push_back("maps");
  const Json& measured = json.value("sets", empty).value(cell.set, empty).value("methods", empty);
  std::string method = candidates.back();
  for (const auto& candidate : candidates)
    if (measured.contains(candidate)) {
      method = candidate;
      break;
    }
  const std::string estimated_as = method == candidates.front() || cell.method == "transfer" ? "" : method;
  try {
    entry = &json.at("sets").at(cell.set).at("methods").at(method);
  } catch (const Json::exception&) {
    throw std::runtime_error(path + " has no cost for " + method + " on " + cell.set +
                             " (re-measure: maps suite calibrate)");
  }
  if (!entry->is_object())
    throw std::runtime_error(path + ": sets." + cell.set + ".methods." + method + " is " + entry->dump() +
                             "; expected an object of costs (re-measure: maps suite calibrate)");
  const std::string cpu = recorded_cpu(entry->contains("cpu") ? *entry : json);
  // A measured cost: a finite number >= 0 (positive where it divides), or `fallback` when absent and allowed.
  const auto cost = [&](const char* key, bool positive, std::optional<double> fallback = std::nullopt) {
    const std::string where = path + ": sets." + cell.set + ".methods." + method + "." + key;
    if (!entry->contains(key)) {
      if (fallback) return *fallback;
      throw std::runtime_error(where + " is missing (re-measure: maps suite calibrate)");
    }
    const Json& value = entry->at(key);
    if (!value.is_number() || !std::isfinite(value.get<double>()) || value.get<double>() < 0 ||
        (positive && value.get<double>() <= 0))
      throw std::runtime_error(where + " is " + value.dump() + "; expected a finite number " +
                               (positive ? "> 0" : ">= 0") + " (re-measure: maps suite calibrate)");
    return value.get<double>();
  };
  const Json& r = cell.request;
  // An evaluation step's work against the calibrated run's (Diffusion Policy: sampling steps per executed action),
  // where the entry records it; MAPS standing in calls its policy once an env step: the cell's work against 1.
  double episode_scale = 1.0;
  if (registered && registered->evaluation_work && (method == "maps" || entry->contains("evaluation_work")))
    episode_scale = registered->evaluation_work(own) / (method == "maps" ? 1.0 : cost("evaluation_work", true));
  const double episode_seconds = cost("episode_seconds", true) * episode_scale;
  // A step's rows: the batch, and for MAML its query batch too (maml.cpp: support + query rows per task).
  double rows = r["train"]["states_per_task"].get<double>(), measured_rows = cost("states_per_task", true);
  if (method == "maml" && entry->contains("query_per_task")) {
    rows += r["maml"]["query_per_task"].get<double>();
    measured_rows += cost("query_per_task", false);
  }
  // The policy's size against the measured one's: a step and a validation grow with it.
  double policy_scale = 1.0;
  if (method == "maps") {
    policy_scale = r["maps"]["modules"].get<double>() / cost("modules", true);
  } else {
    // A baseline's products grow with the square of its width (measured at 3 x 128).
    double width = 0.0;
    for (const auto& h : r["baselines"]["hidden"]) width += h.get<double>();
    width /= static_cast<double>(std::max<std::size_t>(1, r["baselines"]["hidden"].size()));
    policy_scale = std::max(1.0, (width / 128.0) * (width / 128.0));
  }
  double model_scale = policy_scale;
  // Measured with every task of the set in each batch and evaluated; data.tasks and data.holdout keep fewer.
  const auto set_tasks = envs::task_names(cell.set);
  double tasks = 0.0;
  for (const auto& task : set_tasks) {
    const auto& only = r["data"].value("tasks", Json::array());
    const auto& held = r["data"].value("holdout", Json::array());
    const bool kept = (only.empty() || std::find(only.begin(), only.end(), task) != only.end()) &&
                      std::find(held.begin(), held.end(), task) == held.end();
    tasks += kept ? 1.0 : 0.0;
  }
  model_scale *= tasks / static_cast<double>(set_tasks.size());
  const auto& scored = r["eval"].value("tasks", Json::array());
  const double evaluated_tasks = scored.empty() ? tasks : static_cast<double>(scored.size());
  // A GAIL cell: its env steps at the measured cost of one (rollout, discriminator, PPO, validation: every part grows
  // with the env steps at the default gail settings), plus the warm-up's extra discriminator steps. Of an env step,
  // only the policy's part (its calls in the rollouts and PPO's epochs) grows with the policy's size: the physics and
  // the discriminator stay; a table measured before that part was recorded prices every size as the measured one.
  if (r.value("imitation", std::string("bc")) == "gail") {
    if (!entry->contains("gail_env_step_seconds"))
      throw std::runtime_error(path + " has no GAIL cost for " + method + " on " + cell.set + " (cell " + cell.name +
                               " trains by GAIL: maps suite calibrate --gail-env-steps N)");
    const Json& g = r["gail"];
    const double warmup_updates =
        g["discriminator_warmup_iterations"].get<double>() *
        std::max(0.0, g["discriminator_warmup_updates"].get<double>() - g["discriminator_updates"].get<double>());
    const double env_step =
        cost("gail_env_step_seconds", true) + (policy_scale - 1.0) * cost("gail_policy_env_step_seconds", false, 0.0);
    const double training = g["env_steps_per_task"].get<double>() * tasks * env_step +
                            warmup_updates * cost("gail_discriminator_update_seconds", false, 0.0);
    const bool size_unpriced = policy_scale != 1.0 && !entry->contains("gail_policy_env_step_seconds");
    return {.overhead = cost("overhead_seconds", false),
            .training = training,
            .evaluation = r["eval"]["episodes"].get<double>() * evaluated_tasks * episode_seconds,
            .validation = 0.0,
            .checkpointing = 0.0,
            .estimated_as = estimated_as,
            .key = candidates.front(),
            .cpu = cpu,
            .size_unpriced = size_unpriced};
  }
  // A bf16 cell's steps at their own measured cost (validation and evaluation run float32 in both).
  const bool bf16 = r["train"].value("precision", std::string("float32")) == "bf16";
  if (bf16 && !entry->contains("step_seconds_bf16"))
    throw std::runtime_error(path + " has no bf16 step cost for " + method + " on " + cell.set + " (cell " + cell.name +
                             " trains with train.precision bf16; re-measure on a CPU with "
                             "AVX512-BF16: maps suite calibrate)");
  const double step = cost(bf16 ? "step_seconds_bf16" : "step_seconds", true) * rows / measured_rows * model_scale;
  // With kept checkpoints the evaluation runs once more for each (maps eval --checkpoints).
  const double keep_every = r["train"].value("keep_every", 0.0);
  const double evaluations = 1.0 + (keep_every > 0 ? std::floor(r["train"]["steps"].get<double>() / keep_every) : 0.0);
  // Validation scores the validation states (as many whatever the batch) with the same model;
  // a checkpoint writes the parameters and Adam's state.
  const double steps = r["train"]["steps"].get<double>();
  const auto count_every = [steps](double every) { return every > 0 ? std::ceil(steps / every) : 0.0; };
  const double validations = count_every(r["train"]["validate_every"].get<double>());
  const double writes = count_every(r["train"]["checkpoint_every"].get<double>()) +
                        std::floor(keep_every > 0 ? steps / keep_every : 0.0) + validations;
  // A validation scores validation_states_per_task states of each task, whatever the batch.
  const double validation_states =
      r["train"]["validation_states_per_task"].get<double>() /
      cost("validation_states_per_task", true, r["train"]["validation_states_per_task"].get<double>());
  const double validation = validations * cost("validation_seconds", false, 0.0) * model_scale * validation_states;
  const double checkpointing = writes * cost("checkpoint_seconds", false, 0.0);
  return {.overhead = cost("overhead_seconds", false),
          .training = steps * step + validation + checkpointing,
          .evaluation = evaluations * r["eval"]["episodes"].get<double>() * evaluated_tasks * episode_seconds,
          .validation = validation,
          .checkpointing = checkpointing,
          .estimated_as = estimated_as,
          .key = candidates.front(),
          .cpu = cpu};
}

double CostTable::collect_seconds(const std::string& set) const {
  return json.at("sets").at(set).value("collect_seconds", 0.0);
}

fs::path default_costs_path() {
  return envs::find_source_folder("experiments/suites", "MAPS_SUITES_DIR") / "costs.json";
}

CostTable load_costs(const std::string& path) {
  CostTable table;
  table.path = path.empty() ? default_costs_path().string() : path;
  table.json = read_json_file(table.path);
  if (!table.json.is_object() || !table.json.contains("sets") || !table.json["sets"].is_object())
    throw std::runtime_error(table.path +
                             ": not a cost table (expected \"sets\"; write one with maps suite calibrate)");
  for (const auto& [name, set] : table.json["sets"].items())
    if (!set.is_object() || !set.contains("methods") || !set["methods"].is_object())
      throw std::runtime_error(table.path + ": sets." + name + " is not a set's costs (expected an object with an " +
                               "object \"methods\"; write one with maps suite calibrate)");
  return table;
}

std::optional<CostTable> try_load_costs(const std::string& path, bool quiet) {
  try {
    return load_costs(path);
  } catch (const std::exception& e) {
    if (!quiet) std::fprintf(stderr, "suite: no time estimates: %s\n", e.what());
    return std::nullopt;
  }
}

}  // namespace maps::experiments
