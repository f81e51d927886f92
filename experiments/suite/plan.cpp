// `maps suite plan`: a suite's cells, their count and their estimated CPU time.

#include "experiments/suite/plan.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "envs/task_sets.h"
#include "experiments/suite/costs.h"
#include "experiments/suite/folder.h"

namespace maps::experiments {

namespace fs = std::filesystem;

namespace {

// One line saying what the plan's estimate rests on: `what`, then the entries (none: no line).
void print_named(const char* what, const std::set<std::string>& entries) {
  if (entries.empty()) return;
  std::string named;
  for (const auto& entry : entries) named += (named.empty() ? "" : ", ") + entry;
  std::printf("%s: %s\n", what, named.c_str());
}

}  // namespace
using Json = nlohmann::json;

int run_suite_plan(const SuitePlanOptions& options) {
  const Suite suite = load_suite(options.config_path, options.precision);
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
  // Where the CPU time goes: training steps, validation, checkpoint writes, evaluation, and the rest (start-up,
  // reading the demonstrations).
  double steps_part = 0.0, validation_part = 0.0, checkpoint_part = 0.0, evaluation_part = 0.0, other_part = 0.0;
  Json cell_list = Json::array();
  // "method on set" that the table has not measured, estimated as another method's cost: said, so that an estimate
  // resting on a stand-in is not read as measured.
  std::set<std::string> unmeasured;
  std::set<std::string> cpus;  // where the entries the plan used were timed
  // "method on set" of GAIL cells of another policy size priced at the measured one (CellCost::size_unpriced).
  std::set<std::string> size_unpriced;
  for (const auto* cell : cells) {
    const CostTable::CellCost cost = costs.cell_cost(*cell);
    if (cost.size_unpriced) size_unpriced.insert(cost.key + " on " + cell->set);
    if (!cost.estimated_as.empty())
      unmeasured.insert(cost.key + " on " + cell->set +
                        (cost.estimated_as == "maps" ? "" : " (as " + cost.estimated_as + ")"));
    cpus.insert(cost.cpu);
    const double seconds = cost.total();
    total += seconds;
    steps_part += cost.training - cost.validation - cost.checkpointing;
    validation_part += cost.validation;
    checkpoint_part += cost.checkpointing;
    evaluation_part += cost.evaluation;
    other_part += cost.overhead;
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
    // A GAIL cell's budget is its env steps per task.
    group.steps = cell->request.value("imitation", std::string("bc")) == "gail"
                      ? cell->request["gail"]["env_steps_per_task"].get<long long>()
                      : cell->request["train"]["steps"].get<long long>();
    group.episodes = cell->request["eval"]["episodes"].get<int>();
    Json entry = cell->identity();
    entry["estimated_seconds"] = seconds;
    entry["estimated_evaluation_seconds"] = cost.evaluation;
    entry["cost_entry"] = cost.estimated_as.empty() ? cost.key : cost.estimated_as;
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
                      {"cpu_seconds_parts",
                       {{"steps", steps_part},
                        {"validation", validation_part},
                        {"checkpoints", checkpoint_part},
                        {"evaluation", evaluation_part},
                        {"start_and_data", other_part}}},
                      {"collect_seconds", collect},
                      {"jobs", jobs},
                      {"wall_seconds", total / jobs + collect},
                      {"costs", costs.path},
                      {"unmeasured", unmeasured},
                      {"gail_size_unpriced", size_unpriced},
                      {"measured_on", cpus}}
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
  std::printf(
      "| grid | set | method | variant | demos per task | seeds | steps (GAIL: env steps per task) | episodes | cells "
      "| CPU |\n");
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
  if (total > 0)
    std::printf(
        "\nof which training steps %.1f%%, validation %.1f%%, checkpoints %.1f%% (at most), evaluation %.1f%%, "
        "start-up and data %.1f%%",
        100 * steps_part / total, 100 * validation_part / total, 100 * checkpoint_part / total,
        100 * evaluation_part / total, 100 * other_part / total);
  std::string measured_on;
  for (const auto& cpu : cpus) measured_on += (measured_on.empty() ? "" : " and ") + cpu;
  if (measured_on.empty()) measured_on = recorded_cpu(costs.json);
  std::printf("\ncosts: %s (measured on %s; `maps suite calibrate` re-measures on this machine)\n", costs.path.c_str(),
              measured_on.c_str());
  print_named(
      "not measured, estimated at MAPS's cost per step and episode unless another is named (the table predates "
      "them: maps suite calibrate --methods NAME adds them)",
      unmeasured);
  print_named(
      "GAIL cells of another width or module count priced at the measured size (the entry has no policy part, "
      "gail_policy_env_step_seconds: maps suite calibrate --gail-env-steps N --methods NAME adds it)",
      size_unpriced);
  return 0;
}

}  // namespace maps::experiments
