// `maps suite merge`: the finished cells of shard folders of one suite, copied into one folder.

#include "experiments/suite/merge.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <optional>
#include <set>
#include <stdexcept>

#include "envs/mujoco_env.h"
#include "experiments/process/host.h"
#include "experiments/run/run_folder.h"
#include "experiments/suite/folder.h"
#include "io/json_input.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

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
    if (name == suite_files::kLock || name == run_files::kLastCheckpoint || is_temporary(name)) continue;
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
  for (const auto& entry : replaced_entries(dir)) {
    try {
      const Json old = read_json_file((entry / suite_files::kResult).string());
      if (old.contains("finished") && old["finished"].is_string()) times.insert(old["finished"].get<std::string>());
    } catch (const std::exception&) {
    }
  }
  return times;
}

// Whether one of the cell's replaced/ folders holds this very result.
bool replaced_holds(const fs::path& dir, const Json& result) {
  for (const auto& entry : replaced_entries(dir)) {
    try {
      if (read_json_file((entry / suite_files::kResult).string()) == result) return true;
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
        return envs::read_text_file(folder / suite_files::kResult) ==
               envs::read_text_file(entry.path() / suite_files::kResult);
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
  for (const char* name : {run_files::kCurve, suite_files::kResult})
    if (fs::exists(from / name)) fs::copy_file(from / name, kept / name, fs::copy_options::overwrite_existing);
}

}  // namespace

int run_suite_merge(const SuiteMergeOptions& options) {
  if (options.shards.empty()) throw std::invalid_argument("maps suite merge: name at least one shard folder");
  const fs::path out(options.out);
  Suite first = read_manifest(options.shards.front());
  const Json manifest = read_json_file((fs::path(options.shards.front()) / suite_files::kManifest).string());
  for (const auto& shard : options.shards) {
    if (fs::exists(out) && fs::equivalent(shard, out))
      throw std::invalid_argument("maps suite merge: --out " + options.out + " is also a shard");
    const Json other = read_json_file((fs::path(shard) / suite_files::kManifest).string());
    if (other.value("cells", Json()) != manifest.value("cells", Json()))
      throw std::runtime_error(shard + " is a shard of another suite than " + options.shards.front() +
                               " (their suite.json cells differ)");
  }
  fs::create_directories(out);
  if (fs::exists(out / suite_files::kManifest)) {
    if (read_json_file((out / suite_files::kManifest).string()).value("cells", Json()) !=
        manifest.value("cells", Json()))
      throw std::runtime_error(options.out + " holds another suite; merge into a new folder");
  } else {
    write_json_file((out / suite_files::kManifest).string(), manifest);
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

}  // namespace maps::experiments
