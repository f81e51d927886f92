// `maps suite status`, `maps suite merge` and `maps report`.

#include "experiments/suite_status.h"

#include <unistd.h>

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
#include "envs/source_folders.h"
#include "experiments/output_path.h"
#include "experiments/run_folder.h"
#include "experiments/suite_costs.h"
#include "experiments/suite_folder.h"
#include "experiments/suite_run.h"
#include "io/json_input.h"
#include "maps/training/curve_cost.h"
#include "maps/training/trainer.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// The last step curve.csv records (-1 when none: missing, only the header, or unreadable). A running cell may be
// writing its last line: only whole lines (ended by a newline) count.
long long curve_last_step(const fs::path& dir) {
  std::ifstream in(dir / "curve.csv", std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto end = text.rfind('\n');
  if (end == std::string::npos || end == 0) return -1;
  const auto before = text.rfind('\n', end - 1);
  const std::size_t begin = before == std::string::npos ? 0 : before + 1;
  const std::string last = text.substr(begin, end - begin);
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

std::string progress_text(long long step, long long steps) {
  return step < 0 ? "" : "step " + std::to_string(step) + " of " + std::to_string(steps);
}

double share_of(long long step, long long steps) {
  return step <= 0 || steps <= 0 ? 0.0 : std::min(1.0, static_cast<double>(step) / static_cast<double>(steps));
}

// A finished cell's files but its .lock, temporaries and last.ckpt (what resuming needs; a finished cell never resumes,
// and best.ckpt, the policy evaluated, stays). Copies, not hard links: a shard folder edited later must not change the
// merged one.
void copy_cell(const fs::path& source, const fs::path& target) {
  for (const auto& entry : fs::recursive_directory_iterator(source)) {
    const fs::path to = target / fs::relative(entry.path(), source);
    if (entry.is_directory()) {
      fs::create_directories(to);
      continue;
    }
    const fs::path name = entry.path().filename();
    if (name == ".lock" || name == "last.ckpt" || is_temporary(name)) continue;
    fs::create_directories(to.parent_path());
    fs::copy_file(entry.path(), to);
  }
}

// Whether two results of one cell agree number for number (wall times, hosts and dates aside).
// Both were accepted by read_result, which checked these keys.
bool same_numbers(const Json& a, const Json& b) {
  return same_run_config(a.at("config"), b.at("config")) &&
         a.at("eval").at("mean_score") == b.at("eval").at("mean_score") &&
         a.at("eval").at("tasks") == b.at("eval").at("tasks") &&
         a.at("train").at("best_step") == b.at("train").at("best_step") &&
         a.at("train").at("best_validation_bc") == b.at("train").at("best_validation_bc");
}

// The "finished" times of the results a cell's reruns replaced (its replaced/ folders, which retire_cell names for
// them; result.json's "replaces" lists the same).
std::set<std::string> replaced_finish_times(const fs::path& dir) {
  std::set<std::string> times;
  if (!fs::is_directory(dir / kReplacedFolder)) return times;
  for (const auto& entry : fs::directory_iterator(dir / kReplacedFolder)) {
    try {
      const Json old = read_json_file((entry.path() / "result.json").string());
      if (old.contains("finished") && old["finished"].is_string()) times.insert(old["finished"].get<std::string>());
    } catch (const std::exception&) {
    }
  }
  return times;
}

// Whether one of the cell's replaced/ folders holds this very result.
bool replaced_holds(const fs::path& dir, const Json& result) {
  if (!fs::is_directory(dir / kReplacedFolder)) return false;
  for (const auto& entry : fs::directory_iterator(dir / kReplacedFolder)) {
    try {
      if (read_json_file((entry.path() / "result.json").string()) == result) return true;
    } catch (const std::exception&) {
    }
  }
  return false;
}

std::string finish_time(const Json& result) {
  return result.contains("finished") && result["finished"].is_string() ? result["finished"].get<std::string>() : "";
}

// Whether a transfer cell's result started from a run of its source cell that was run again since (the source's
// replaced/ holds it): such a result is stale even where the cell itself was never retired.
bool from_replaced_source(const fs::path& target, const Json& result) {
  const Json source = result.value("source", Json());
  if (!source.is_object() || !source.contains("cell") || !source["cell"].is_string() || !source.contains("finished") ||
      !source["finished"].is_string())
    return false;
  const std::string cell = source["cell"].get<std::string>();
  if (cell.empty() || cell.find('/') != std::string::npos || cell == "..") return false;
  return replaced_finish_times(target.parent_path() / cell).count(source["finished"].get<std::string>()) > 0;
}

// Copies the replaced/ folders of `from` that `to` lacks into `to`: a rerun merged over a cell keeps its record. A
// folder of the same name holding another result.json is kept under a name of its own.
void keep_replaced(const fs::path& from, const fs::path& to) {
  if (!fs::is_directory(from / kReplacedFolder)) return;
  fs::create_directories(to / kReplacedFolder);
  for (const auto& entry : fs::directory_iterator(from / kReplacedFolder)) {
    const std::string name = entry.path().filename().string();
    fs::path kept = to / kReplacedFolder / name;
    auto same_result = [&](const fs::path& folder) {
      try {
        return envs::read_text_file(folder / "result.json") == envs::read_text_file(entry.path() / "result.json");
      } catch (const std::exception&) {
        return false;
      }
    };
    for (int n = 2; fs::exists(kept) && !same_result(kept); ++n)
      kept = to / kReplacedFolder / (name + "-" + std::to_string(n));
    if (!fs::exists(kept)) fs::copy(entry.path(), kept, fs::copy_options::recursive);
  }
}

// Copies a cell's result.json and curve.csv into to/replaced/ (the folder retire_cell would move them to).
void keep_result(const fs::path& from, const Json& result, const fs::path& to) {
  const fs::path kept = replaced_folder(to, finish_time(result));
  fs::create_directories(kept);
  for (const char* name : {"curve.csv", "result.json"})
    if (fs::exists(from / name)) fs::copy_file(from / name, kept / name, fs::copy_options::overwrite_existing);
}

struct CellState {
  std::string state, detail;
  double cost_seconds = -1.0;  // a finished cell's (set_cost; -1: not finished or not recorded)
  bool cost_from_curve = false;
  double trained = 0.0;  // a running cell's share of training its curve records, a started one's its last.ckpt holds
};

// A finished cell's cost: training from curve.csv (every attempt; CPU time where the curve has it) plus the
// evaluation's seconds. result.json's wall_seconds, the fallback, times only the attempt that finished the cell and
// grows with pauses.
void set_cost(CellState& s, const fs::path& dir, const Json& result) {
  const Json& eval_seconds = result.at("eval").contains("seconds") ? result.at("eval").at("seconds") : Json();
  const Json& steps = result.at("train").contains("steps") ? result.at("train").at("steps") : Json();
  if (eval_seconds.is_number() && steps.is_number_integer())
    if (const auto training = core::curve_training_cost((dir / "curve.csv").string(), steps.get<std::int64_t>())) {
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

CellState state_in(const fs::path& out, const SuiteCell& cell) {
  const fs::path dir = cell_dir(out, cell);
  CellState s;
  std::string damage;
  const long long steps = cell.request["train"]["steps"].get<long long>();
  if (const auto result = read_result(dir, cell, &damage)) {
    s.state = "done";
    char text[128];
    std::snprintf(text, sizeof(text), "mean score %.3f, best step %lld", result->at("eval").value("mean_score", 0.0),
                  static_cast<long long>(result->at("eval").value("best_step", -1LL)));
    s.detail = text;
    set_cost(s, dir, *result);
  } else if (cell_is_locked(dir)) {
    s.state = "running";
    const long long step = curve_last_step(dir);
    s.detail = progress_text(step, steps);
    s.trained = share_of(step, steps);
  } else if (fs::exists(dir / "error.json")) {
    s.state = "failed";
    try {
      const Json error = read_json_file((dir / "error.json").string());
      s.detail = io::string_or(error, "stage", "?") + ": " + io::string_or(error, "error", "?") + " (see " +
                 (dir / io::string_or(error, "log", "")).string() + ")";
    } catch (const std::exception& e) {
      s.detail = e.what();
    }
  } else if (fs::exists(dir / "last.ckpt")) {
    s.state = "started";
    // It resumes from last.ckpt's step (its curve may record more, which a resume truncates).
    try {
      const long long step = core::trained_steps(dir.string());
      s.detail = "resumable at its last checkpoint, " + progress_text(step, steps);
      s.trained = share_of(step, steps);
    } catch (const std::exception& e) {
      s.detail = std::string("its last checkpoint cannot be read, so it cannot resume: ") + e.what();
    }
  } else {
    s.state = "left";
  }
  if (!damage.empty()) s.detail += (s.detail.empty() ? "" : "; ") + damage;
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

}  // namespace

int run_suite_status(const SuiteStatusOptions& options) {
  if (options.dirs.empty()) throw std::invalid_argument("maps suite status: name a suite folder");
  const Suite suite = read_manifest(options.dirs.front());
  for (std::size_t i = 1; i < options.dirs.size(); ++i)
    if (read_json_file((fs::path(options.dirs[i]) / "suite.json").string()).value("cells", Json()) !=
        read_json_file((fs::path(options.dirs.front()) / "suite.json").string()).value("cells", Json()))
      throw std::runtime_error(options.dirs[i] + " is a folder of another suite than " + options.dirs.front() +
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
  std::map<std::string, int> counts;
  // Per grid, in the suite's order: a long study is followed grid by grid.
  std::vector<std::string> grids;
  std::map<std::string, std::map<std::string, int>> by_grid;
  Json cells = Json::array();
  std::vector<std::string> lines;
  std::vector<CellState> states;
  for (const auto& cell : suite.cells) {
    CellState best{.state = "left", .detail = ""};
    for (const auto& dir : options.dirs) {
      const CellState here = state_in(dir, cell);
      if (rank_of(here.state) > rank_of(best.state) || (best.detail.empty() && here.state == best.state)) best = here;
    }
    if ((best.state == "left" || best.state == "started") && !current.count(cell.name))
      best = {.state = "dropped", .detail = "no longer in the suite's config"};
    states.push_back(best);
  }
  // Only the config's cells run, so only they count.
  std::vector<const SuiteCell*> config_cells;
  std::set<std::string> finished;
  for (std::size_t i = 0; i < suite.cells.size(); ++i) {
    if (current.count(suite.cells[i].name)) config_cells.push_back(&suite.cells[i]);
    if (states[i].state == "done") finished.insert(suite.cells[i].name);
  }
  const CellsRunAgain again =
      cells_to_run_again(config_cells, finished, std::vector<fs::path>(options.dirs.begin(), options.dirs.end()));
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
    counts[best.state] += 1;
    if (!by_grid.count(cell.grid)) grids.push_back(cell.grid);
    by_grid[cell.grid][best.state] += 1;
    Json entry = cell.identity();
    entry["state"] = best.state;
    entry["detail"] = best.detail;
    if (again.finished.count(cell.name)) entry["runs_again"] = true;
    cells.push_back(entry);
    if (options.all || best.state == "failed" || best.state == "running" || best.state == "started")
      lines.push_back(best.state + "  " + cell.name + (best.detail.empty() ? "" : ": " + best.detail));
  }
  std::string where = options.dirs.front();
  if (options.dirs.size() > 1) where += " and " + std::to_string(options.dirs.size() - 1) + " more folders";
  const auto costs = try_load_costs("", true);
  const std::optional<TimeLeft> time = costs ? time_left(suite, states, again, *costs) : std::nullopt;
  if (options.json) {
    Json status{{"dirs", options.dirs}, {"counts", counts}, {"cells", cells}};
    if (time) {
      status["cpu_seconds_left"] = time->table;
      if (time->paced) status["cpu_seconds_left_at_pace"] = *time->paced;
    }
    std::cout << status.dump(1) << "\n";
    return 0;
  }
  for (const auto& line : lines) std::printf("%s\n", line.c_str());
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

int run_suite_merge(const SuiteMergeOptions& options) {
  if (options.shards.empty()) throw std::invalid_argument("maps suite merge: name at least one shard folder");
  const fs::path out(options.out);
  Suite first = read_manifest(options.shards.front());
  const Json manifest = read_json_file((fs::path(options.shards.front()) / "suite.json").string());
  for (const auto& shard : options.shards) {
    if (fs::exists(out) && fs::equivalent(shard, out))
      throw std::invalid_argument("maps suite merge: --out " + options.out + " is also a shard");
    const Json other = read_json_file((fs::path(shard) / "suite.json").string());
    if (other.value("cells", Json()) != manifest.value("cells", Json()))
      throw std::runtime_error(shard + " is a shard of another suite than " + options.shards.front() +
                               " (their suite.json cells differ)");
  }
  fs::create_directories(out);
  if (fs::exists(out / "suite.json")) {
    if (read_json_file((out / "suite.json").string()).value("cells", Json()) != manifest.value("cells", Json()))
      throw std::runtime_error(options.out + " holds another suite; merge into a new folder");
  } else {
    write_json_file((out / "suite.json").string(), manifest);
  }
  const fs::path staging_root = out / (".merging-" + host_name() + "-" + std::to_string(::getpid()));
  for (const auto& entry : fs::directory_iterator(out))
    if (entry.path().filename().string().rfind(".merging-", 0) == 0)
      std::printf(
          "note: %s is left from a merge that was stopped; a cell's earlier copy (<cell>.earlier) may be in "
          "it: look, then remove it\n",
          entry.path().string().c_str());
  int merged = 0, finished = 0, stale = 0;
  // A transfer's result is judged against its source's replaced/ records in out, so its source is merged first.
  for (const SuiteCell* listed : sources_first(first)) {
    const SuiteCell& cell = *listed;
    const fs::path target = cell_dir(out, cell);
    std::optional<Json> have = read_result(target, cell);
    for (const auto& shard : options.shards) {
      const fs::path source = cell_dir(shard, cell);
      const auto result = read_result(source, cell);
      if (!result) continue;
      // A result that a rerun of the cell replaced is not merged over the rerun.
      const std::string time = finish_time(*result);
      if ((!time.empty() && replaced_finish_times(target).count(time)) || from_replaced_source(target, *result)) {
        std::printf("%s: %s's result of %s was run again since (or its source was); not merged\n", cell.name.c_str(),
                    shard.c_str(), time.c_str());
        // Kept on record as a replaced result, as the run that superseded it would have kept it.
        if (!replaced_holds(target, *result) && !cell_is_locked(target)) keep_result(source, *result, target);
        ++stale;
        continue;
      }
      if (have) {
        if (same_numbers(*have, *result)) continue;
        const std::string have_time = finish_time(*have);
        if ((have_time.empty() || !replaced_finish_times(source).count(have_time)) &&
            !from_replaced_source(source, *have))
          throw std::runtime_error("cell " + cell.name + " has different results in " + shard +
                                   " and in another shard or " + options.out +
                                   " (neither is a rerun that replaced the other); not merged");
      }
      if (cell_is_locked(target))
        throw std::runtime_error("cell " + cell.name + " is being run in " + options.out +
                                 " (its .lock is held); merge into a folder no suite is running in");
      // Staged outside cells/, so a merge killed halfway leaves nothing that looks like a cell.
      const fs::path staging = staging_root / cell.name;
      fs::remove_all(staging);
      fs::create_directories(staging.parent_path());
      fs::create_directories(target.parent_path());
      copy_cell(source, staging);
      // The result superseded here stays on record beside the rerun's, unless the rerun kept it itself.
      if (have && !replaced_holds(staging, *have)) keep_result(target, *have, staging);
      if (fs::exists(target)) keep_replaced(target, staging);
      // The target is untouched until here, and then swapped in two renames: a merge killed between them leaves
      // the earlier cell in the staging folder, which is not removed then.
      const fs::path earlier = staging_root / (cell.name + ".earlier");
      if (fs::exists(target)) {
        fs::remove_all(earlier);
        fs::create_directories(earlier.parent_path());
        fs::rename(target, earlier);
      }
      fs::rename(staging, target);
      fs::remove_all(earlier);
      have = result;
      ++merged;
    }
    if (have) ++finished;
  }
  fs::remove_all(staging_root);
  std::printf("merged %d cells from %zu shards into %s: %d of %zu cells finished", merged, options.shards.size(),
              options.out.c_str(), finished, first.cells.size());
  if (stale > 0)
    std::printf(" (%d results left out: their cells, or the sources they started from, were run again since)", stale);
  std::printf("\n");
  return 0;
}

int run_report(const ReportOptions& options) {
  const fs::path script = envs::find_source_folder("experiments/suites", "MAPS_SUITES_DIR") / "report.py";
  if (!fs::exists(script)) throw std::runtime_error("the report script " + script.string() + " is missing");
  if (!fs::exists(fs::path(options.dir) / "suite.json"))
    throw std::runtime_error(options.dir + " is not a suite folder: it has no suite.json (maps suite run writes it)");
  const std::string out = options.out.empty() ? (fs::path(options.dir) / "report").string() : options.out;
  check_output_folder("--out", out);
  const std::string python = "/usr/bin/python3";  // Debian's, with matplotlib (scripts/setup.sh)
  if (!fs::exists(python))
    throw std::runtime_error("maps report needs " + python + " with matplotlib (bash scripts/setup.sh installs it)");
  const int code = run_program(python, {script.string(), options.dir, out}, nullptr);
  if (code == 127) throw std::runtime_error("cannot run " + python);
  return code;
}

}  // namespace maps::experiments
