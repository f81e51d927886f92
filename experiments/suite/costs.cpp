// The cost table: measured costs and the estimate of a cell's CPU time.

#include "experiments/suite/costs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
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

CostTable::CellCost CostTable::cell_cost(const SuiteCell& cell) const {
  const Json* entry = nullptr;
  // A transfer cell trains MAPS (for one task, from a trained run). A method the table has not measured (one added
  // to the registry since) is estimated as MAPS, whose parameter budget the zoo's methods match by default.
  std::string method = cell.method == "transfer" ? "maps" : cell.method;
  const Json empty = Json::object();
  if (!json.value("sets", empty).value(cell.set, empty).value("methods", empty).contains(method)) method = "maps";
  try {
    entry = &json.at("sets").at(cell.set).at("methods").at(method);
  } catch (const Json::exception&) {
    throw std::runtime_error(path + " has no cost for " + method + " on " + cell.set +
                             " (re-measure: maps suite calibrate)");
  }
  const Json& c = *entry;
  const Json& r = cell.request;
  // A step's rows: the batch, and for MAML its query batch too (maml.cpp: support + query rows per task).
  double rows = r["train"]["states_per_task"].get<double>(), measured_rows = c.at("states_per_task").get<double>();
  if (method == "maml" && c.contains("query_per_task")) {
    rows += r["maml"]["query_per_task"].get<double>();
    measured_rows += c.at("query_per_task").get<double>();
  }
  double step = c.at("step_seconds").get<double>() * rows / measured_rows;
  if (method == "maps") {
    step *= r["maps"]["modules"].get<double>() / c.at("modules").get<double>();
  } else {
    // A baseline's products grow with the square of its width (measured at 3 x 128).
    double width = 0.0;
    for (const auto& h : r["baselines"]["hidden"]) width += h.get<double>();
    width /= static_cast<double>(std::max<std::size_t>(1, r["baselines"]["hidden"].size()));
    step *= std::max(1.0, (width / 128.0) * (width / 128.0));
  }
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
  step *= tasks / static_cast<double>(set_tasks.size());
  const auto& scored = r["eval"].value("tasks", Json::array());
  const double evaluated_tasks = scored.empty() ? tasks : static_cast<double>(scored.size());
  // With kept checkpoints the evaluation runs once more for each (maps eval --checkpoints).
  const double keep_every = r["train"].value("keep_every", 0.0);
  const double evaluations = 1.0 + (keep_every > 0 ? std::floor(r["train"]["steps"].get<double>() / keep_every) : 0.0);
  return {.overhead = c.at("overhead_seconds").get<double>(),
          .training = r["train"]["steps"].get<double>() * step,
          .evaluation = evaluations * r["eval"]["episodes"].get<double>() * evaluated_tasks *
                        c.at("episode_seconds").get<double>()};
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
