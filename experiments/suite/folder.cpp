#include "experiments/suite/folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <deque>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <stdexcept>
#include <vector>

#include "experiments/process/plugins.h"
#include "experiments/run/run_folder.h"
#include "io/config_schema.h"
#include "io/json_input.h"
#include "maps/training/run_config.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

fs::path cell_dir(const fs::path& out, const SuiteCell& cell) { return out / "cells" / cell.name; }

Json suite_manifest(const Suite& suite, const std::vector<SuiteCell>& cells) {
  Json list = Json::array();
  for (const auto& cell : cells) {
    Json entry = cell.identity();
    entry["request"] = cell.request;
    list.push_back(entry);
  }
  return {{"format", kSuiteFormat}, {"config_file", suite.path}, {"config", suite.source}, {"cells", list}};
}

Suite read_manifest(const fs::path& out) {
  const fs::path path = out / suite_files::kManifest;
  if (!fs::exists(path))
    throw std::runtime_error(out.string() + " is not a suite folder: it has no suite.json (maps suite run writes it)");
  const Json manifest = read_json_file(path.string());
  if (!manifest.is_object() || io::string_or(manifest, "format", "") != kSuiteFormat || !manifest.contains("cells") ||
      !manifest["cells"].is_array())
    throw std::runtime_error(path.string() + ": not a " + std::string(kSuiteFormat) +
                             " manifest (expected \"format\" and \"cells\")");
  Suite suite;
  suite.path = io::string_or(manifest, "config_file", "");
  suite.source = manifest.value("config", Json::object());
  try {
    std::set<std::string> names;
    for (const auto& entry : manifest["cells"]) {
      // Each integer within its range: read as an int, 2^32 + 1 demonstrations became 1.
      const auto integer = [&](const char* key, long double low, long double high) {
        io::Field field;
        field.key = "cells[" + std::to_string(suite.cells.size()) + "]." + key;
        field.kind = io::ValueKind::kInteger;
        field.min = low;
        field.max = high;
        try {
          io::check_value(field, entry.at(key), "");
        } catch (const std::invalid_argument& e) {
          throw std::runtime_error(path.string() + ": " + e.what());
        }
        return entry.at(key);
      };
      SuiteCell cell;
      cell.index = integer("index", 0, 100000000).get<int>();
      const auto text = [&](const char* key) {
        if (!entry.contains(key) || !entry.at(key).is_string())
          throw std::runtime_error(path.string() + ": cells[" + std::to_string(suite.cells.size()) + "]." + key +
                                   ": expected a string");
        return entry.at(key).get<std::string>();
      };
      cell.name = text("name");
      if (cell.name.empty() || !names.insert(cell.name).second)
        throw std::runtime_error(path.string() + ": cell name '" + cell.name + "' is empty or given twice");
      cell.grid = text("grid");
      cell.set = text("set");
      cell.method = text("method");
      cell.variant = text("variant");
      cell.demos = integer("demos", 1, 1000000).get<int>();
      cell.subsample = integer("subsample", 1, 1000000).get<int>();
      cell.seed = integer("seed", 0, io::kMaxUint64).get<std::uint64_t>();
      // Resolved (every key, defaults filled in), as a suite config's cells are: status, plan and the cost table
      // read keys of it, and a hand-edited manifest may leave some out.
      try {
        cell.request =
            core::to_json(core::parse_run_config(load_config_plugins(entry.at("request"), ".", path.string())));
      } catch (const std::exception& e) {
        throw std::runtime_error(path.string() + ": cell " + cell.name + " has a damaged run config (" + e.what() +
                                 ")");
      }
      suite.cells.push_back(std::move(cell));
    }
  } catch (const Json::exception& e) {
    throw std::runtime_error(path.string() + ": a cell entry is damaged (" + e.what() + ")");
  }
  return suite;
}

void write_or_check_manifest(const fs::path& out, const Suite& suite) {
  fs::create_directories(out);
  const fs::path path = out / suite_files::kManifest;
  std::vector<SuiteCell> cells = suite.cells;
  if (fs::exists(path)) {
    const Suite old = read_manifest(out);
    std::map<std::string, const SuiteCell*> now;
    for (const auto& cell : suite.cells) now[cell.name] = &cell;
    for (const auto& cell : old.cells) {
      const auto found = now.find(cell.name);
      if (found != now.end() && !same_run_config(found->second->request, cell.request))
        throw std::runtime_error(
            out.string() + " holds a suite whose cell " + cell.name + " has another run config than " + suite.path +
            " gives it (" +
            run_config_differences(cell.request, found->second->request, "the folder's", "the config's") +
            "); use a new --out, or delete that cell's folder and its entry");
    }
    // Cells of the old manifest that the new config drops stay listed, so status and report still see them.
    for (const auto& cell : old.cells)
      if (!now.count(cell.name)) {
        cells.push_back(cell);
        cells.back().index = static_cast<int>(cells.size()) - 1;
      }
    if (read_json_file(path.string()) == suite_manifest(suite, cells)) return;
  }
  write_json_file(path.string(), suite_manifest(suite, cells));
}

bool same_run_config(const Json& a, const Json& b) {
  if (a == b) return true;
  try {
    return core::to_json(core::parse_run_config(load_config_plugins(a, ".", "a run config"))) ==
           core::to_json(core::parse_run_config(load_config_plugins(b, ".", "a run config")));
  } catch (const std::exception&) {
    return false;
  }
}

namespace {

std::string short_dump(const Json& value) {
  std::string text = value.is_null() ? std::string("absent") : value.dump();
  return text.size() > 40 ? text.substr(0, 37) + "..." : text;
}

void collect_differences(const Json& a, const Json& b, const std::string& path, std::vector<std::string>& out,
                         const std::string& a_name, const std::string& b_name) {
  if (a.is_object() && b.is_object()) {
    std::set<std::string> keys;
    for (const auto& [key, value] : a.items()) keys.insert(key);
    for (const auto& [key, value] : b.items()) keys.insert(key);
    for (const auto& key : keys)
      collect_differences(a.contains(key) ? a[key] : Json(), b.contains(key) ? b[key] : Json(),
                          path.empty() ? key : path + "." + key, out, a_name, b_name);
    return;
  }
  if (a != b) out.push_back(path + ": " + short_dump(a) + " in " + a_name + ", " + short_dump(b) + " in " + b_name);
}

}  // namespace

std::string run_config_differences(const Json& a, const Json& b, const std::string& a_name, const std::string& b_name) {
  const auto resolved = [](const Json& config, const std::string& name, std::string& error) -> Json {
    try {
      return core::to_json(core::parse_run_config(load_config_plugins(config, ".", "a run config")));
    } catch (const std::exception& e) {
      error = name + " is no run config (" + e.what() + ")";
      return Json();
    }
  };
  std::string error;
  const Json ra = resolved(a, a_name, error), rb = error.empty() ? resolved(b, b_name, error) : Json();
  if (!error.empty()) return error;
  std::vector<std::string> found;
  collect_differences(ra, rb, "", found, a_name, b_name);
  std::string text;
  for (std::size_t i = 0; i < found.size() && i < 3; ++i) text += (i ? "; " : "") + found[i];
  if (found.size() > 3) text += "; and " + std::to_string(found.size() - 3) + " more";
  return text;
}

bool is_temporary(const fs::path& file) {
  const std::string name = file.filename().string();
  return name.find(".tmp-") != std::string::npos || name.ends_with(".tmp") || name.ends_with(".partial.h5");
}

void remove_temporaries(const fs::path& dir) {
  if (!fs::exists(dir)) return;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.is_regular_file() && is_temporary(entry.path())) fs::remove(entry.path());
}

std::optional<Json> read_result(const fs::path& dir, const SuiteCell& cell, std::string* damage) {
  if (damage) damage->clear();
  const fs::path path = dir / suite_files::kResult;
  if (!fs::exists(path)) return std::nullopt;
  auto reject = [&](const std::string& why) -> std::optional<Json> {
    if (damage) *damage = path.string() + ": " + why;
    return std::nullopt;
  };
  Json result;
  try {
    result = read_json_file(path.string());
  } catch (const std::exception& e) {
    return reject("unreadable (" + std::string(e.what()) + ")");
  }
  if (!result.is_object() || io::string_or(result, "format", "") != kCellFormat)
    return reject("not a maps-suite-cell/1 result");
  if (!result.contains("cell") || !result["cell"].is_object() || io::string_or(result["cell"], "name", "") != cell.name)
    return reject("names another cell");
  if (!result.contains("config") || !same_run_config(result["config"], cell.request))
    return reject("was trained with another run config (" +
                  run_config_differences(result.value("config", Json()), cell.request, "its config", "the suite's") +
                  ")");
  const auto number = [](const Json& object, const char* key) {
    return object.is_object() && object.contains(key) && object[key].is_number();
  };
  // Steps are read as integers later (suite run's summary): 1e300 there would not convert.
  const auto step = [](const Json& object, const char* key) {
    return object.is_object() && object.contains(key) && object[key].is_number_integer();
  };
  if (!result.contains("train") || !step(result["train"], "steps") || !step(result["train"], "best_step") ||
      !number(result["train"], "best_validation_bc"))
    return reject("has no training summary (steps, best_step, best_validation_bc)");
  const Json& eval = result.contains("eval") ? result["eval"] : Json();
  if (!number(eval, "mean_score") || !step(eval, "best_step") || !eval.contains("tasks") || !eval["tasks"].is_array() ||
      eval["tasks"].empty())
    return reject("has no evaluation (mean_score, best_step, tasks)");
  for (const auto& task : eval["tasks"])
    if (!number(task, "score") || !task.contains("task") || !task["task"].is_string())
      return reject("has an evaluation task without a name or a score");
  // MAPS's module usage: per task, a distribution over the same modules (the report's routing tables read it so).
  const Json& first = eval["tasks"].front();
  const std::size_t modules =
      first.contains("module_usage") && first["module_usage"].is_array() ? first["module_usage"].size() : 0;
  for (const auto& task : eval["tasks"]) {
    if (!task.contains("module_usage")) continue;
    const Json& usage = task["module_usage"];
    bool fine = usage.is_array() && usage.size() == modules;
    for (std::size_t m = 0; fine && m < usage.size(); ++m)
      fine = usage[m].is_number() && std::isfinite(usage[m].get<double>()) && usage[m].get<double>() >= 0.0;
    if (!fine)
      return reject("task " + task["task"].get<std::string>() +
                    ": module_usage is not a distribution over the same modules as " +
                    first["task"].get<std::string>() + "'s");
  }
  return result;
}

CellLock::CellLock(const fs::path& dir) {
  fs::create_directories(dir);
  const std::string path = (dir / suite_files::kLock).string();
  fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw std::runtime_error("cannot open '" + path + "': " + std::strerror(errno));
  // A few tries: `maps suite status` probes the lock for an instant (a shared lock), which must not make a
  // runner skip the cell.
  for (int attempt = 0; attempt < 5; ++attempt) {
    if (::flock(fd_, LOCK_EX | LOCK_NB) == 0) return;
    ::usleep(20000);
  }
  ::close(fd_);
  fd_ = -1;
}

CellLock::~CellLock() {
  if (fd_ >= 0) ::close(fd_);
}

bool cell_is_locked(const fs::path& dir) {
  const std::string path = (dir / suite_files::kLock).string();
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool locked = ::flock(fd, LOCK_SH | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);
  return locked;
}

fs::path source_dir(const fs::path& dir, const SuiteCell& cell) {
  const std::string relative = cell.request.contains("init") ? io::string_or(cell.request["init"], "run", "") : "";
  if (relative.empty()) return {};
  // "../a/" names the folder "../a" does: without the trailing separator, so that both find the same cell.
  const fs::path source = (dir / relative).lexically_normal();
  return source.has_filename() ? source : source.parent_path();
}

fs::path source_checkpoint(const fs::path& dir, const SuiteCell& cell) {
  const fs::path source = source_dir(dir, cell);
  if (source.empty()) return {};
  return source / io::string_or(cell.request["init"], "checkpoint", run_files::kBestCheckpoint);
}

void clear_cell(const fs::path& dir) {
  if (!fs::exists(dir)) return;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().filename() != suite_files::kLock && entry.path().filename() != kReplacedFolder)
      fs::remove_all(entry.path());
}

std::vector<fs::path> replaced_entries(const fs::path& dir) {
  std::vector<fs::path> entries;
  if (!fs::is_directory(dir / kReplacedFolder)) return entries;
  for (const auto& entry : fs::directory_iterator(dir / kReplacedFolder)) entries.push_back(entry.path());
  std::sort(entries.begin(), entries.end());
  return entries;
}

fs::path replaced_folder(const fs::path& dir, std::string finished) {
  std::replace(finished.begin(), finished.end(), ':', '-');
  // It names a folder: anything but a time as utc_now writes it (a hand-edited result) is not trusted.
  static const std::regex time_like(R"(\d{4}-\d{2}-\d{2}T\d{2}-\d{2}-\d{2}Z)");
  if (!std::regex_match(finished, time_like)) finished = "unknown";
  fs::path kept = dir / kReplacedFolder / finished;
  // A folder without result.json is this cell's own, left half moved by a crash in retire_cell.
  for (int n = 2; fs::exists(kept / suite_files::kResult); ++n)
    kept = dir / kReplacedFolder / (finished + "-" + std::to_string(n));
  return kept;
}

fs::path retire_cell(const fs::path& dir) {
  std::string finished;
  try {
    finished = io::string_or(read_json_file((dir / suite_files::kResult).string()), "finished", finished);
  } catch (const std::exception&) {
  }
  const fs::path kept = replaced_folder(dir, finished);
  fs::create_directories(kept);
  // result.json last: a cell whose result.json is still in place after a crash here is retired again.
  for (const char* name : {run_files::kCurve, suite_files::kResult})
    if (fs::exists(dir / name)) fs::rename(dir / name, kept / name);
  clear_cell(dir);
  return kept;
}

std::vector<const SuiteCell*> sources_first(const Suite& suite) {
  std::map<fs::path, const SuiteCell*> by_dir;
  for (const auto& cell : suite.cells) by_dir[cell_dir("", cell)] = &cell;
  std::vector<const SuiteCell*> order;
  std::set<const SuiteCell*> placed;
  // Depth first: a cell's chain of sources is placed before it, each cell once.
  std::function<void(const SuiteCell*, std::set<const SuiteCell*>&)> place = [&](const SuiteCell* cell,
                                                                                 std::set<const SuiteCell*>& path) {
    if (placed.count(cell) || !path.insert(cell).second) return;
    if (const auto source = by_dir.find(source_dir(cell_dir("", *cell), *cell)); source != by_dir.end())
      place(source->second, path);
    if (placed.insert(cell).second) order.push_back(cell);
  };
  for (const auto& cell : suite.cells) {
    std::set<const SuiteCell*> path;
    place(&cell, path);
  }
  return order;
}

std::vector<std::pair<fs::path, const SuiteCell*>> suite_descendants(
    const std::map<fs::path, std::vector<const SuiteCell*>>& dependants, const fs::path& out, const fs::path& source) {
  std::vector<std::pair<fs::path, const SuiteCell*>> found;
  std::set<fs::path> seen{source};
  std::deque<fs::path> next{source};
  while (!next.empty()) {
    const auto at = dependants.find(next.front());
    next.pop_front();
    if (at == dependants.end()) continue;
    for (const auto* cell : at->second) {
      const fs::path dir = cell_dir(out, *cell).lexically_normal();
      if (!seen.insert(dir).second) continue;
      found.emplace_back(dir, cell);
      next.push_back(dir);
    }
  }
  return found;
}

namespace {

// The cells that start from each cell folder (keys as cell_dir(out, cell).lexically_normal()).
std::map<fs::path, std::vector<const SuiteCell*>> dependants_of(const fs::path& out,
                                                                const std::vector<const SuiteCell*>& cells) {
  std::map<fs::path, std::vector<const SuiteCell*>> dependants;
  for (const auto* cell : cells)
    if (const fs::path source = source_dir(cell_dir(out, *cell).lexically_normal(), *cell); !source.empty())
      dependants[source].push_back(cell);
  return dependants;
}

// A source runs again when a cell that will train starts from it and its checkpoint is gone; its finished dependants
// then run again too, which may in turn need their own source to: repeated until nothing changes. `to_run` (the cell
// folders that will train) grows with each source found and its group. Status and run share this, so that what
// status says runs again is what run retires.
std::vector<fs::path> sources_to_run_again(const std::map<fs::path, std::vector<const SuiteCell*>>& dependants,
                                           const std::set<fs::path>& in_suite, const fs::path& out,
                                           std::set<fs::path>& to_run,
                                           const std::function<bool(const SuiteCell&)>& has_source_checkpoint) {
  const auto checkpoint_missing = [&](const std::vector<const SuiteCell*>& cells_from_it) {
    return std::any_of(cells_from_it.begin(), cells_from_it.end(), [&](const SuiteCell* cell) {
      return to_run.count(cell_dir(out, *cell).lexically_normal()) && !has_source_checkpoint(*cell);
    });
  };
  std::vector<fs::path> sources;
  for (bool changed = true; changed;) {
    changed = false;
    for (const auto& [source, cells_from_it] : dependants) {
      if (!in_suite.count(source) || to_run.count(source) || !checkpoint_missing(cells_from_it)) continue;
      sources.push_back(source);
      to_run.insert(source);
      for (const auto& member : suite_descendants(dependants, out, source)) to_run.insert(member.first);
      changed = true;
    }
  }
  return sources;
}

}  // namespace

CellsRunAgain cells_to_run_again(const std::vector<const SuiteCell*>& cells, const std::set<std::string>& finished,
                                 const std::vector<fs::path>& dirs) {
  // Folders relative to the suite's (""): the same in every folder of `dirs`.
  const auto dependants = dependants_of("", cells);
  std::set<fs::path> in_suite, to_run;
  std::map<fs::path, const SuiteCell*> by_dir;
  for (const auto* cell : cells) {
    const fs::path dir = cell_dir("", *cell).lexically_normal();
    in_suite.insert(dir);
    by_dir[dir] = cell;
    if (!finished.count(cell->name)) to_run.insert(dir);
  }
  const auto has_source_checkpoint = [&](const SuiteCell& cell) {
    return std::any_of(dirs.begin(), dirs.end(),
                       [&](const fs::path& dir) { return fs::exists(source_checkpoint(cell_dir(dir, cell), cell)); });
  };
  CellsRunAgain again;
  for (const auto& source : sources_to_run_again(dependants, in_suite, "", to_run, has_source_checkpoint)) {
    again.finished.insert(by_dir.at(source)->name);
    for (const auto& member : suite_descendants(dependants, "", source))
      (finished.count(member.second->name) ? again.finished : again.restarted).insert(member.second->name);
  }
  return again;
}

std::set<fs::path> retire_sources_without_checkpoint(const fs::path& out, const std::vector<const SuiteCell*>& cells) {
  const auto dependants = dependants_of(out, cells);
  std::map<fs::path, const SuiteCell*> by_dir;
  std::set<fs::path> in_suite;
  std::set<fs::path> to_run;  // the cells that will train: unfinished, or retired here
  for (const auto* cell : cells) {
    const fs::path dir = cell_dir(out, *cell).lexically_normal();
    by_dir[dir] = cell;
    in_suite.insert(dir);
    if (!read_result(dir, *cell)) to_run.insert(dir);
  }
  const auto group_of = [&](const fs::path& source) { return suite_descendants(dependants, out, source); };
  std::vector<fs::path> sources = sources_to_run_again(dependants, in_suite, out, to_run, [&](const SuiteCell& cell) {
    return fs::exists(source_checkpoint(cell_dir(out, cell).lexically_normal(), cell));
  });
  // Only the outermost sources: the group of one holds every source inside it, so a group another process holds
  // any cell of is left whole, none of it retired first.
  std::set<fs::path> inside;
  for (const auto& source : sources)
    for (const auto& member : group_of(source)) inside.insert(member.first);
  std::erase_if(sources, [&](const fs::path& source) { return inside.count(source) > 0; });
  std::set<fs::path> held_elsewhere;
  for (const auto& source : sources) {
    const SuiteCell& source_cell = *by_dir.at(source);
    const auto& cells_from_it = dependants.at(source);
    const std::string checkpoint =
        source_checkpoint(cell_dir(out, *cells_from_it.front()), *cells_from_it.front()).filename().string();
    const auto group = group_of(source);
    std::vector<fs::path> folders{source};
    for (const auto& member : group) folders.push_back(member.first);
    // Every cell of the group is taken before any is touched, so that a process running one of them stops this.
    std::vector<std::unique_ptr<CellLock>> locks;
    fs::path busy;
    for (const auto& dir : folders) {
      locks.push_back(std::make_unique<CellLock>(dir));
      if (!locks.back()->held()) {
        busy = dir;
        break;
      }
    }
    if (!busy.empty()) {
      // Its dependants would fail at once (their source has no checkpoint): this process leaves the group to the
      // one that holds it.
      std::printf(
          "suite: %s is finished but its %s is gone, and cells that start from it are left; another "
          "process holds %s, so this one leaves the source and its %zu dependants to it\n",
          source_cell.name.c_str(), checkpoint.c_str(), busy.string().c_str(), group.size());
      held_elsewhere.insert(folders.begin(), folders.end());
      continue;
    }
    // Checked again under the locks: another process may have retired and rerun it meanwhile, or an earlier group
    // here may hold it.
    if (!read_result(source, source_cell) ||
        std::all_of(cells_from_it.begin(), cells_from_it.end(),
                    [&](const SuiteCell* cell) { return fs::exists(source_checkpoint(cell_dir(out, *cell), *cell)); }))
      continue;
    // The farthest dependants first, the source last: should this stop half way, the source still lacks its
    // checkpoint and the next run of the suite takes the group up again.
    int retired = 0;
    for (auto member = group.rbegin(); member != group.rend(); ++member) {
      if (read_result(member->first, *member->second)) {
        retire_cell(member->first);
        ++retired;
      } else {
        clear_cell(member->first);  // a part-trained run from an earlier source
      }
    }
    retire_cell(source);
    std::printf(
        "suite: %s is finished but its %s is gone (checkpoints are not kept with the results), and "
        "cells that start from it are left: it and the %d finished ones that started from it run again, the "
        "unfinished ones from the start (results so far are kept in their %s/ folders)\n",
        source_cell.name.c_str(), checkpoint.c_str(), retired, kReplacedFolder);
  }
  std::fflush(stdout);
  return held_elsewhere;
}

}  // namespace maps::experiments
