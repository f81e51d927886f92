// The cost table, `maps suite plan` and `maps suite calibrate`.

#include "experiments/suite_costs.h"

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
#include "experiments/cpu_model.h"
#include "experiments/run_folder.h"
#include "experiments/suite_folder.h"
#include "experiments/suite_run.h"
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

int run_suite_plan(const SuitePlanOptions& options) {
  const Suite suite = load_suite(options.config_path);
  const auto [shard, shards] = parse_shard(options.shard);
  const auto cells = shard_cells(suite, shard, shards);
  const CostTable costs = load_costs(options.costs);
  const int jobs = options.jobs > 0 ? options.jobs : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));

  // Groups of cells that differ only in demos and seed, in the suite's order.
  struct Group {
    std::string grid, set, method, variant;
    std::set<int> demos;
    std::set<std::uint64_t> seeds;
    int cells = 0;
    double seconds = 0.0;
    long long steps = 0;
    int episodes = 0;
  };
  std::vector<Group> groups;
  std::map<std::string, std::size_t> group_of;
  double total = 0.0;
  Json cell_list = Json::array();
  for (const auto* cell : cells) {
    const double seconds = costs.cell_seconds(*cell);
    total += seconds;
    const std::string key = cell->grid + "|" + cell->set + "|" + cell->method + "|" + cell->variant;
    auto [it, inserted] = group_of.emplace(key, groups.size());
    if (inserted) {
      groups.emplace_back();
      groups.back().grid = cell->grid;
      groups.back().set = cell->set;
      groups.back().method = cell->method;
      groups.back().variant = cell->variant;
    }
    Group& group = groups[it->second];
    group.demos.insert(cell->demos);
    group.seeds.insert(cell->seed);
    group.cells += 1;
    group.seconds += seconds;
    group.steps = cell->request["train"]["steps"].get<long long>();
    group.episodes = cell->request["eval"]["episodes"].get<int>();
    Json entry = cell->identity();
    entry["estimated_seconds"] = seconds;
    entry["shard_key"] = shard_key(suite, *cell);
    cell_list.push_back(entry);
  }
  std::set<std::string> missing_files;
  double collect = 0.0;
  for (const auto* cell : cells) {
    const std::string& file = suite.sets.at(cell->set).demo_file;
    if (!fs::exists(file) && missing_files.insert(file).second) collect += costs.collect_seconds(cell->set);
  }

  if (options.json) {
    std::cout << Json{{"config", options.config_path},
                      {"shard", shard},
                      {"shards", shards},
                      {"cells", cell_list},
                      {"count", cells.size()},
                      {"cpu_seconds", total},
                      {"collect_seconds", collect},
                      {"jobs", jobs},
                      {"wall_seconds", total / jobs + collect},
                      {"costs", costs.path}}
                     .dump(1)
              << "\n";
    return 0;
  }
  auto list = [](const auto& values) {
    std::string out = "{";
    for (const auto& v : values) {
      if (out.size() > 1) out += ",";
      out += std::to_string(v);
    }
    return out += "}";
  };
  if (options.list_cells) {
    std::printf("| index | cell | grid | steps | episodes | estimated CPU |\n|---|---|---|---|---|---|\n");
    for (const auto& entry : cell_list)
      std::printf("| %d | %s | %s | %lld | %d | %s |\n", entry["index"].get<int>(),
                  entry["name"].get<std::string>().c_str(), entry["grid"].get<std::string>().c_str(),
                  suite.cells[entry["index"].get<std::size_t>()].request["train"]["steps"].get<long long>(),
                  suite.cells[entry["index"].get<std::size_t>()].request["eval"]["episodes"].get<int>(),
                  format_duration(entry["estimated_seconds"].get<double>()).c_str());
    std::printf("\n");
  }
  std::printf("| grid | set | method | variant | demos per task | seeds | steps | episodes | cells | CPU |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& g : groups)
    std::printf("| %s | %s | %s | %s | %s | %s | %lld | %d | %d | %s |\n", g.grid.c_str(), g.set.c_str(),
                g.method.c_str(), g.variant.c_str(), list(g.demos).c_str(), list(g.seeds).c_str(), g.steps, g.episodes,
                g.cells, format_duration(g.seconds).c_str());
  std::printf("\n%s%s: %zu cells, estimated %.1f CPU-hours (%s) at one thread per cell", options.config_path.c_str(),
              shards > 1 ? (" shard " + options.shard).c_str() : "", cells.size(), total / 3600.0,
              format_duration(total).c_str());
  std::printf("; %s of wall time on %d jobs", format_duration(total / jobs + collect).c_str(), jobs);
  if (collect > 0)
    std::printf(" (with %s collecting %zu missing demo files)", format_duration(collect).c_str(), missing_files.size());
  std::printf("\ncosts: %s (measured on %s; `maps suite calibrate` re-measures on this machine)\n", costs.path.c_str(),
              costs.json.value("cpu", std::string("an unnamed CPU")).c_str());
  return 0;
}

int run_suite_calibrate(const SuiteCalibrateOptions& options) {
  const std::string out = options.out.empty() ? default_costs_path().string() : options.out;
  // The per-set settings of the paper's scale (batch, selector weights, MAML query) at a short budget.
  const Suite paper = load_suite((default_costs_path().parent_path() / "paper.json").string());
  Json calibrated_methods = Json::array();
  for (const auto& method : core::policy_methods()) calibrated_methods.push_back(method.name);
  Json sets = Json::object();
  for (const auto& set_name : options.sets) {
    if (!paper.sets.count(set_name))
      throw std::invalid_argument("--sets: '" + set_name + "' is not a set of experiments/suites/paper.json");
    Json config = paper.source;
    config["grids"] = Json::array({{{"name", "calibrate"},
                                    {"sets", {set_name}},
                                    {"methods", calibrated_methods},
                                    {"demos", {paper.sets.at(set_name).demos.front()}},
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
    if (!had_file)
      entry["collect_seconds"] =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - collect_start).count();
    const fs::path work = fs::path(options.work) / set_name;
    fs::remove_all(work);
    for (const auto& cell : suite.cells) {
      const CellOutcome outcome = run_cell(work, cell, 1);
      if (outcome.status != CellOutcome::Status::kFinished)
        throw std::runtime_error("calibration cell " + cell.name + " did not finish: " + outcome.error);
      const Json& result = outcome.result;
      const double train_seconds = result["train"]["seconds_this_process"].get<double>();
      const double eval_seconds = result["eval"]["seconds"].get<double>();
      const double tasks = static_cast<double>(result["eval"]["tasks"].size());
      const Json method{{"step_seconds", train_seconds / options.steps},
                        {"states_per_task", cell.request["train"]["states_per_task"]},
                        {"modules", cell.request["maps"]["modules"]},
                        {"query_per_task", cell.request["maml"]["query_per_task"]},
                        {"episode_seconds", eval_seconds / (options.episodes * tasks)},
                        {"overhead_seconds", std::max(0.0, outcome.seconds - train_seconds - eval_seconds)}};
      std::printf("calibrate: %s: %.2f ms per step, %.3f s per episode, %.1f s overhead\n", cell.name.c_str(),
                  1e3 * method["step_seconds"].get<double>(), method["episode_seconds"].get<double>(),
                  method["overhead_seconds"].get<double>());
      std::fflush(stdout);
      entry["methods"][cell.method] = method;
    }
    sets[set_name] = entry;
  }
  // Sets not re-measured keep their old entries (collect times are kept when the file existed).
  Json table = Json::object();
  if (fs::exists(out)) table = read_json_file(out);
  for (auto& [name, entry] : sets.items()) {
    if (!entry.contains("collect_seconds") && table.contains("sets") && table["sets"].contains(name))
      entry["collect_seconds"] = table["sets"][name].value("collect_seconds", 0.0);
    table["sets"][name] = entry;
  }
  table["cpu"] = cpu_model();
  table["measured"] = utc_now();
  table["command"] = "maps suite calibrate --steps " + std::to_string(options.steps) + " --episodes " +
                     std::to_string(options.episodes);
  table["note"] =
      "one thread per cell, one cell at a time; step_seconds includes validation at validate_every = steps / 2";
  write_json_file(out, table);
  std::printf("calibrate: wrote %s\n", out.c_str());
  return 0;
}

}  // namespace maps::experiments
