// `maps suite status`: what each cell of a suite folder (or of its shard folders) is.

#include "experiments/suite/status.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>

#include "envs/mujoco_env.h"
#include "envs/task_sets.h"
#include "experiments/run/run_folder.h"
#include "experiments/suite/costs.h"
#include "experiments/suite/folder.h"
#include "io/json_input.h"
#include "maps/adversarial/gail_state.h"
#include "maps/training/curve_cost.h"
#include "maps/training/trainer.h"
#include "nn/serialize.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// The last step curve.csv records in its column `column` (0: a BC run's step; 1: a GAIL run's env steps per task),
// -1 when none: missing, only the header, or unreadable. A running cell may be writing its last line: only whole
// lines (ended by a newline) count.
long long curve_last_step(const fs::path& dir, int column = 0) {
  std::ifstream in(dir / run_files::kCurve, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto end = text.rfind('\n');
  if (end == std::string::npos || end == 0) return -1;
  const auto before = text.rfind('\n', end - 1);
  const std::size_t begin = before == std::string::npos ? 0 : before + 1;
  std::string last = text.substr(begin, end - begin);
  for (int c = 0; c < column; ++c) {
    const auto comma = last.find(',');
    if (comma == std::string::npos) return -1;
    last = last.substr(comma + 1);
  }
  const auto comma = last.find(',');
  if (last.empty() || comma == std::string::npos) return -1;
  try {
    std::size_t used = 0;
    const long long step = std::stoll(last.substr(0, comma), &used);
    return used == comma && step >= 0 ? step : -1;
  } catch (const std::exception&) {
    return -1;
  }
}

std::string progress_text(long long step, long long steps, bool gail = false) {
  return step < 0 ? ""
                  : (gail ? "env steps per task " : "step ") + std::to_string(step) + " of " + std::to_string(steps);
}

double share_of(long long step, long long steps) {
  return step <= 0 || steps <= 0 ? 0.0 : std::min(1.0, static_cast<double>(step) / static_cast<double>(steps));
}

struct CellState {
  std::string state, detail;
  std::string folder;             // the cell folder the state was read from
  std::string damage;             // why its result.json does not count ("" : none, or none there)
  Json error;                     // a failed cell's error.json: {"stage", "error"}
  Json replaced = Json::array();  // its earlier results (replaced/*/result.json): {"folder", "damage"}
  double cost_seconds = -1.0;     // a finished cell's (set_cost; -1: not finished or not recorded)
  bool cost_from_curve = false;
  double trained = 0.0;  // a running cell's share of training its curve records, a started one's its last.ckpt holds
};

// A finished cell's cost: training from curve.csv (every attempt; CPU time where the curve has it; a GAIL cell's
// iterations, gail_curve_training_cost) plus the evaluation's seconds. result.json's wall_seconds, the fallback, times
// only the attempt that finished the cell and grows with pauses.
void set_cost(CellState& s, const fs::path& dir, const Json& result) {
  const Json& eval_seconds = result.at("eval").contains("seconds") ? result.at("eval").at("seconds") : Json();
  const Json& train = result.at("train");
  const Json& steps = train.contains("steps") ? train.at("steps") : Json();
  const bool gail = train.contains("imitation") && train.at("imitation") == "gail";
  if (gail && eval_seconds.is_number() && train.contains("env_steps_per_task") &&
      train.at("env_steps_per_task").is_number_integer() && result.at("eval").contains("tasks") &&
      result.at("eval").at("tasks").is_array())
    if (const auto training = core::gail_curve_training_cost(
            (dir / run_files::kCurve).string(), train.at("env_steps_per_task").get<std::int64_t>(),
            static_cast<std::int64_t>(result.at("eval").at("tasks").size()))) {
      s.cost_seconds = training->seconds + eval_seconds.get<double>();
      s.cost_from_curve = true;
      return;
    }
  if (!gail && eval_seconds.is_number() && steps.is_number_integer())
    if (const auto training =
            core::curve_training_cost((dir / run_files::kCurve).string(), steps.get<std::int64_t>())) {
      s.cost_seconds = training->seconds + eval_seconds.get<double>();
      s.cost_from_curve = true;
      return;
    }
  const Json& wall = result.contains("wall_seconds") ? result.at("wall_seconds") : Json();
  if (wall.is_number()) s.cost_seconds = wall.get<double>();
}

// done > running > failed > started > left: what a cell is, over the folders that may hold it.
int rank_of(const std::string& state) {
  static const std::map<std::string, int> ranks{{"done", 4}, {"running", 3}, {"failed", 2}, {"started", 1}};
  const auto found = ranks.find(state);
  return found == ranks.end() ? 0 : found->second;
}

// read_result's damage, "<folder>/result.json: why", without the path (the status gives the folder apart).
std::string damage_reason(const fs::path& folder, const std::string& damage) {
  const std::string prefix = (folder / suite_files::kResult).string() + ": ";
  return damage.starts_with(prefix) ? damage.substr(prefix.size()) : damage;
}

// The results of the cell's earlier runs (retire_cell keeps them in replaced/<time>/), each judged as a result of
// this cell is: "damage" says why one does not count as an earlier run of this cell's run config.
Json replaced_results_of(const fs::path& dir, const SuiteCell& cell) {
  Json list = Json::array();
  for (const auto& folder : replaced_entries(dir)) {
    if (!fs::is_directory(folder)) continue;
    std::string damage;
    Json entry{{"folder", folder.string()}};
    if (!fs::exists(folder / suite_files::kResult))
      damage = "has no result.json";
    else if (!read_result(folder, cell, &damage) && damage.empty())
      damage = "unreadable";
    if (!damage.empty()) entry["damage"] = damage_reason(folder, damage);
    list.push_back(entry);
  }
  return list;
}

CellState state_in(const fs::path& out, const SuiteCell& cell) {
  const fs::path dir = cell_dir(out, cell);
  CellState s;
  s.folder = dir.string();
  std::string damage;
  // A GAIL cell's progress is its env steps per task (curve.csv's second column, last.ckpt's record).
  const bool gail = cell.request.value("imitation", std::string("bc")) == "gail";
  const long long steps = gail ? cell.request["gail"]["env_steps_per_task"].get<long long>()
                               : cell.request["train"]["steps"].get<long long>();
  if (const auto result = read_result(dir, cell, &damage)) {
    s.state = "done";
    char text[128];
    std::snprintf(text, sizeof(text), "mean score %.3f, best step %lld", result->at("eval").value("mean_score", 0.0),
                  static_cast<long long>(result->at("eval").value("best_step", -1LL)));
    s.detail = text;
    set_cost(s, dir, *result);
  } else if (cell_is_locked(dir)) {
    s.state = "running";
    const long long step = curve_last_step(dir, gail ? 1 : 0);
    s.detail = progress_text(step, steps, gail);
    s.trained = share_of(step, steps);
  } else if (fs::exists(dir / suite_files::kError)) {
    s.state = "failed";
    try {
      const Json error = read_json_file((dir / suite_files::kError).string());
      s.error = {{"stage", io::string_or(error, "stage", "?")},
                 {"error", io::string_or(error, "error", "(no message)")}};
      s.detail = io::string_or(error, "stage", "?") + ": " + io::string_or(error, "error", "?") + " (see " +
                 (dir / io::string_or(error, "log", "")).string() + ")";
    } catch (const std::exception& e) {
      s.error = {{"stage", "?"}, {"error", std::string("unreadable error.json (") + e.what() + ")"}};
      s.detail = e.what();
    }
  } else if (fs::exists(dir / run_files::kLastCheckpoint)) {
    s.state = "started";
    // It resumes from last.ckpt's step (its curve may record more, which a resume truncates).
    try {
      const std::string last = (dir / run_files::kLastCheckpoint).string();
      const long long step =
          gail ? adversarial::read_gail_record(nn::load_tensors(last).config, "GAIL checkpoint " + last)
                     .env_steps_per_task
               : core::trained_steps(dir.string());
      s.detail = "resumable at its last checkpoint, " + progress_text(step, steps, gail);
      s.trained = share_of(step, steps);
    } catch (const std::exception& e) {
      s.detail = std::string("its last checkpoint cannot be read, so it cannot resume: ") + e.what();
    }
  } else {
    s.state = "left";
  }
  if (!damage.empty()) s.detail += (s.detail.empty() ? "" : "; ") + damage;
  s.damage = damage_reason(dir, damage);
  s.replaced = replaced_results_of(dir, cell);
  return s;
}

// The CPU time the cells left need, from the cost table: each cell's estimate less the training a running or
// resumable cell has done (a cell that starts over, none). The table was measured on one machine; the finished cells
// say how the machines they ran on differ, and how far the table is off for each kind of cell (a set's method): a cell
// left is scaled by the finished cells of its kind once 3 of them have finished, else by all finished cells. (Their
// host names a container, not a machine, so the pace is the folder's, not this machine's.) std::nullopt when no cell
// is left or the table cannot price one of them.
struct TimeLeft {
  double table = 0.0;
  std::optional<double> paced;
  std::string pace_note;
};
std::optional<TimeLeft> time_left(const Suite& suite, const std::vector<CellState>& states, const CellsRunAgain& again,
                                  const CostTable& costs) {
  std::vector<std::pair<std::size_t, double>> left_cells;
  TimeLeft time;
  for (std::size_t i = 0; i < suite.cells.size(); ++i) {
    const std::string& name = suite.cells[i].name;
    if ((states[i].state == "done" && !again.finished.count(name)) || states[i].state == "dropped") continue;
    try {
      const CostTable::CellCost cost = costs.cell_cost(suite.cells[i]);
      left_cells.emplace_back(i, cost.total() - states[i].trained * cost.training);
      time.table += left_cells.back().second;
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }
  if (left_cells.empty()) return std::nullopt;
  struct Pace {
    double measured = 0.0, estimated = 0.0;
    int finished = 0, from_curve = 0;
    double ratio() const { return measured / estimated; }
  };
  Pace all;
  std::map<std::string, Pace> by_kind;
  const auto kind_of = [&](std::size_t i) { return suite.cells[i].set + " " + suite.cells[i].method; };
  for (std::size_t i = 0; i < suite.cells.size(); ++i) {
    if (states[i].state != "done" || states[i].cost_seconds <= 0.0) continue;
    try {
      const double estimate = costs.cell_seconds(suite.cells[i]);
      for (Pace* pace : {&all, &by_kind[kind_of(i)]}) {
        pace->estimated += estimate;
        pace->measured += states[i].cost_seconds;
        pace->finished += 1;
        pace->from_curve += states[i].cost_from_curve ? 1 : 0;
      }
    } catch (const std::exception&) {
    }
  }
  if (all.finished < 3 || all.estimated <= 0.0) return time;
  double scaled = 0.0;
  std::map<std::string, int> scaled_by_kind;  // kinds with cells left, scaled by their own pace
  for (const auto& [i, seconds] : left_cells) {
    const auto kind = by_kind.find(kind_of(i));
    const bool own = kind != by_kind.end() && kind->second.finished >= 3 && kind->second.estimated > 0.0;
    scaled += seconds * (own ? kind->second.ratio() : all.ratio());
    if (own) scaled_by_kind[kind->first] += 1;
  }
  char text[256];
  std::snprintf(text, sizeof(text),
                "%d finished cells took %.2fx the table's estimate: training from curve.csv, every attempt, plus "
                "evaluation; %d timed by their last attempt's wall time",
                all.finished, all.ratio(), all.finished - all.from_curve);
  time.pace_note = text;
  std::string kinds;
  for (const auto& [kind, count] : scaled_by_kind) {
    std::snprintf(text, sizeof(text), "%s%s %.2fx (%d left)", kinds.empty() ? "" : ", ", kind.c_str(),
                  by_kind.at(kind).ratio(), count);
    kinds += text;
  }
  if (!kinds.empty())
    time.pace_note += "; the cells of a set's method with 3 or more finished at their own pace: " + kinds;
  time.paced = scaled;
  return time;
}

// What every cell of the folders is, and the counts and estimate the status prints.
struct StatusReport {
  Suite suite;
  std::vector<CellState> states;
  CellsRunAgain again;
  std::map<std::string, int> counts;
  std::optional<TimeLeft> time;
};

StatusReport status_of(const std::vector<std::string>& dirs) {
  if (dirs.empty()) throw std::invalid_argument("maps suite status: name a suite folder");
  StatusReport report;
  report.suite = read_manifest(dirs.front());
  const Suite& suite = report.suite;
  const auto manifest_cells = [](const std::string& dir) {
    return read_json_file((fs::path(dir) / suite_files::kManifest).string()).value("cells", Json());
  };
  const Json first_cells = dirs.size() > 1 ? manifest_cells(dirs.front()) : Json();
  for (std::size_t i = 1; i < dirs.size(); ++i)
    if (manifest_cells(dirs[i]) != first_cells)
      throw std::runtime_error(dirs[i] + " is a folder of another suite than " + dirs.front() +
                               " (their suite.json cells differ)");
  // Cells the folder lists but its config (as last run) no longer makes are "dropped" unless they started running,
  // failed or finished: they will not run, so they are neither left nor in the estimate. A config that no longer parses
  // drops nothing.
  std::set<std::string> current;
  try {
    for (const auto& cell : parse_suite(suite.source, "suite.json config").cells) current.insert(cell.name);
  } catch (const std::exception&) {
    for (const auto& cell : suite.cells) current.insert(cell.name);
  }
  std::vector<CellState>& states = report.states;
  for (const auto& cell : suite.cells) {
    CellState best;
    best.state = "left";
    for (const auto& dir : dirs) {
      const CellState here = state_in(dir, cell);
      if (rank_of(here.state) > rank_of(best.state) || (best.detail.empty() && here.state == best.state)) best = here;
    }
    if ((best.state == "left" || best.state == "started") && !current.count(cell.name)) {
      best = CellState();
      best.state = "dropped";
      best.detail = "no longer in the suite's config";
    }
    states.push_back(best);
  }
  // Only the config's cells run, so only they count.
  std::vector<const SuiteCell*> config_cells;
  std::set<std::string> finished;
  for (std::size_t i = 0; i < suite.cells.size(); ++i) {
    if (current.count(suite.cells[i].name)) config_cells.push_back(&suite.cells[i]);
    if (states[i].state == "done") finished.insert(suite.cells[i].name);
  }
  report.again = cells_to_run_again(config_cells, finished, std::vector<fs::path>(dirs.begin(), dirs.end()));
  const CellsRunAgain& again = report.again;
  for (std::size_t i = 0; i < suite.cells.size(); ++i) {
    const SuiteCell& cell = suite.cells[i];
    CellState& best = states[i];
    if (again.finished.count(cell.name))
      best.detail += std::string(best.detail.empty() ? "" : "; ") +
                     "runs again (the source run's checkpoint is gone while cells that start from it are left)";
    if (again.restarted.count(cell.name) && best.state != "left") {
      best.detail += std::string(best.detail.empty() ? "" : "; ") +
                     "starts over (its source runs again: the source run's checkpoint is gone)";
      best.trained = 0.0;
    }
    report.counts[best.state] += 1;
  }
  const auto costs = try_load_costs("", true);
  if (costs) report.time = time_left(suite, states, again, *costs);
  return report;
}

Json status_json(const std::vector<std::string>& dirs, const StatusReport& report) {
  Json cells = Json::array();
  for (std::size_t i = 0; i < report.suite.cells.size(); ++i) {
    const SuiteCell& cell = report.suite.cells[i];
    const CellState& state = report.states[i];
    Json entry = cell.identity();
    entry["state"] = state.state;
    entry["detail"] = state.detail;
    if (!state.folder.empty()) entry["folder"] = state.folder;
    if (!state.damage.empty()) entry["damage"] = state.damage;
    if (state.state == "failed" && !state.error.is_null()) entry["error"] = state.error;
    if (!state.replaced.empty()) entry["replaced"] = state.replaced;
    if (report.again.finished.count(cell.name)) entry["runs_again"] = true;
    cells.push_back(entry);
  }
  Json status{{"format", kStatusFormat},
              {"dirs", dirs},
              {"task_sets", envs::task_set_names()},
              {"counts", report.counts},
              {"cells", cells}};
  if (report.time) {
    status["cpu_seconds_left"] = report.time->table;
    if (report.time->paced) status["cpu_seconds_left_at_pace"] = *report.time->paced;
  }
  return status;
}

}  // namespace

nlohmann::json suite_status(const std::vector<std::string>& dirs) { return status_json(dirs, status_of(dirs)); }

int run_suite_status(const SuiteStatusOptions& options) {
  const StatusReport report = status_of(options.dirs);
  if (options.json) {
    std::cout << status_json(options.dirs, report).dump(1) << "\n";
    return 0;
  }
  const Suite& suite = report.suite;
  std::map<std::string, int> counts = report.counts;
  const CellsRunAgain& again = report.again;
  const std::optional<TimeLeft>& time = report.time;
  // Per grid, in the suite's order: a long study is followed grid by grid.
  std::vector<std::string> grids;
  std::map<std::string, std::map<std::string, int>> by_grid;
  for (std::size_t i = 0; i < suite.cells.size(); ++i) {
    const SuiteCell& cell = suite.cells[i];
    const CellState& best = report.states[i];
    if (!by_grid.count(cell.grid)) grids.push_back(cell.grid);
    by_grid[cell.grid][best.state] += 1;
    if (options.all || best.state == "failed" || best.state == "running" || best.state == "started")
      std::printf("%s\n", (best.state + "  " + cell.name + (best.detail.empty() ? "" : ": " + best.detail)).c_str());
  }
  std::string where = options.dirs.front();
  if (options.dirs.size() > 1) where += " and " + std::to_string(options.dirs.size() - 1) + " more folders";
  if (grids.size() > 1) {
    std::printf(
        "| grid | cells | done | running | failed | started | left | dropped |\n"
        "|---|---|---|---|---|---|---|---|\n");
    for (const auto& grid : grids) {
      std::map<std::string, int>& n = by_grid[grid];
      std::printf("| %s | %d | %d | %d | %d | %d | %d | %d |\n", grid.empty() ? "-" : grid.c_str(),
                  n["done"] + n["running"] + n["failed"] + n["started"] + n["left"] + n["dropped"], n["done"],
                  n["running"], n["failed"], n["started"], n["left"], n["dropped"]);
    }
  }
  std::printf("%s: %zu cells: %d done, %d running, %d failed, %d started (resumable), %d left", where.c_str(),
              suite.cells.size(), counts["done"], counts["running"], counts["failed"], counts["started"],
              counts["left"]);
  if (counts["dropped"] > 0) std::printf(", %d dropped (no longer in the config)", counts["dropped"]);
  std::printf("\n");
  if (!again.finished.empty())
    std::printf(
        "%zu of the done cells run again: sources whose checkpoint is gone (results keep none) while cells that start "
        "from them are left, with the cells finished from them (maps suite run does this first; --all names them)\n",
        again.finished.size());
  if (time) {
    std::printf(
        "estimated CPU time left: %s (one thread per cell; the part of a running or resumable cell's training "
        "done so far not counted)\n",
        format_duration(time->table).c_str());
    if (time->paced)
      std::printf("at the finished cells' pace: %s (%s)\n", format_duration(*time->paced).c_str(),
                  time->pace_note.c_str());
  }
  return 0;
}

}  // namespace maps::experiments
