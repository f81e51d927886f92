#include "experiments/suite/cell.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <thread>
#include <vector>

#include "autograd/ops.h"
#include "experiments/process/child_process.h"
#include "experiments/process/cpu_model.h"
#include "experiments/process/host.h"
#include "experiments/run/run_folder.h"
#include "experiments/run/training_attempts.h"
#include "experiments/suite/folder.h"
#include "io/json_input.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

void write_error(const fs::path& dir, const std::string& stage, int code, const fs::path& log) {
  write_json_file((dir / suite_files::kError).string(), {{"stage", stage},
                                                         {"exit_code", code},
                                                         {"error", last_line(log)},
                                                         {"log", log.filename().string()},
                                                         {"log_tail", tail_of(log, 20)},
                                                         {"host", host_name()},
                                                         {"time", utc_now()}});
}

// What one attempt at a cell came to.
struct Attempt {
  std::string error;              // "" : result.json written
  bool unreadable_state = false;  // a child exited saying a checkpoint of the folder cannot be read
};

Attempt failed_stage(const fs::path& dir, const std::string& stage, int code, const fs::path& log) {
  write_error(dir, stage, code, log);
  const std::string said = last_line(log);
  Attempt attempt;
  attempt.error =
      (stage == "train" ? "training failed (exit " : "evaluation failed (exit ") + std::to_string(code) + "): " + said;
  // Only a child that ended by itself (not by a signal: OOM, a kill) and named a checkpoint (nn/serialize's
  // "checkpoint <path>: ...") failed on the folder's state; anything else would fail again from nothing.
  attempt.unreadable_state = code > 0 && code < 128 && said.find("checkpoint ") != std::string::npos;
  return attempt;
}

// What the cell's earlier runs came to (replaced/*/result.json), for comparison with this one.
Json replaced_results(const fs::path& dir) {
  Json list = Json::array();
  for (const auto& folder : replaced_entries(dir)) {
    Json entry{{"folder", (fs::path(kReplacedFolder) / folder.filename()).string()}};
    try {
      const Json old = read_json_file((folder / suite_files::kResult).string());
      for (const char* key : {"finished", "cpu", "float32_gemm_kernel"})
        if (old.contains(key)) entry[key] = old[key];
      entry["best_step"] = old.at("train").at("best_step");
      entry["best_validation_bc"] = old.at("train").value("best_validation_bc", Json());
      entry["mean_score"] = old.at("eval").at("mean_score");
    } catch (const std::exception& e) {
      entry["unreadable"] = e.what();
    }
    list.push_back(entry);
  }
  return list;
}

// One attempt: train (resuming), evaluate, write result.json.
Attempt attempt_cell(const fs::path& dir, const SuiteCell& cell, int threads, double& seconds) {
  const auto start = std::chrono::steady_clock::now();
  write_json_file((dir / run_files::kRequest).string(), cell.request);
  const std::string thread_arg = std::to_string(threads);
  // maps train keeps its own train.log in the folder; train.out gets whatever the process printed (a crash too).
  const int train_code = run_self(
      {"train", "--config", (dir / run_files::kRequest).string(), "--out", dir.string(), "--threads", thread_arg},
      dir / suite_files::kTrainOutput);
  if (train_code != 0) return failed_stage(dir, "train", train_code, dir / suite_files::kTrainOutput);
  std::vector<std::string> eval_args{"eval", "--run", dir.string(), "--threads", thread_arg};
  if (cell.request["train"].value("keep_every", 0LL) > 0) eval_args.push_back("--checkpoints");
  const int eval_code = run_self(eval_args, dir / suite_files::kEvalLog);
  if (eval_code != 0) return failed_stage(dir, "eval", eval_code, dir / suite_files::kEvalLog);
  seconds = seconds_since(start);
  Json result{{"format", kCellFormat},
              {"cell", cell.identity()},
              {"config", read_json_file((dir / run_files::kConfig).string())},
              {"train", read_json_file((dir / run_files::kTrainSummary).string())},
              {"eval", read_json_file((dir / run_files::kEval).string())},
              {"wall_seconds", seconds},
              {"threads", threads},
              {"host", host_name()},
              {"cpu", cpu_model()},
              {"float32_gemm_kernel", ag::float32_gemm_kernel()},
              {"training_attempts", training_attempts(dir)},
              {"finished", utc_now()}};
  if (const fs::path source = source_dir(dir, cell); !source.empty()) {
    // Which run of the source it started from, should the source be run again later (retire_cell).
    Json finished;
    try {
      finished = read_json_file((source / suite_files::kResult).string()).value("finished", Json());
    } catch (const std::exception&) {
    }
    result["source"] = {{"cell", source.filename().string()}, {"finished", finished}};
  }
  if (Json replaces = replaced_results(dir); !replaces.empty()) result["replaces"] = replaces;
  if (!same_run_config(result["config"], cell.request))
    return {"the run folder's config.json is not the cell's run config (the folder was changed while it ran)"};
  write_json_file((dir / suite_files::kResult).string(), result);
  fs::remove(dir / suite_files::kError);
  return {};
}

// A transfer cell starts from another cell's best checkpoint (init.run, a sibling folder): it waits while that cell
// runs (here or in another process), and fails, naming it, when the source failed, is neither finished nor running
// (its shard not run yet), or finished without its checkpoint (run_suite retires such a source first). Returns ""
// when the source is finished (or there is none).
std::string wait_for_source(const fs::path& dir, const SuiteCell& cell) {
  const fs::path source = source_dir(dir, cell);
  if (source.empty()) return "";
  const auto start = std::chrono::steady_clock::now();
  bool announced = false;
  for (;;) {
    if (fs::exists(source / suite_files::kResult)) {
      const fs::path checkpoint = source_checkpoint(dir, cell);
      if (fs::exists(checkpoint)) return "";
      return "its source cell " + source.string() + " is finished but its " + checkpoint.filename().string() +
             " is gone (checkpoints are not kept with the results): rerun the suite, "
             "which trains it again, with every cell that starts from it, before the others";
    }
    // A running source is waited for even when an error.json of an earlier attempt is still there; a worker that
    // has just taken the source may not hold its lock (nor have cleared that error.json) yet: allow it a moment
    // (a few seconds when the source has failed, so that a failed source's dependants do not each wait long).
    const bool failed = fs::exists(source / suite_files::kError);
    if (!cell_is_locked(source) && seconds_since(start) > (failed ? 5.0 : 30.0)) {
      // It may have finished between the checks above (writing result.json, then releasing its lock).
      if (fs::exists(source / suite_files::kResult)) continue;  // checked at the top
      if (failed) return "its source cell " + source.string() + " failed (see its error.json)";
      return "its source cell " + source.string() +
             " is neither finished nor running: run the suite (or that cell's shard) so that it finishes first";
    }
    if (!announced) {
      std::printf("suite: %s waits for its source cell %s\n", cell.name.c_str(), source.string().c_str());
      std::fflush(stdout);
      announced = true;
    }
    std::this_thread::sleep_for(std::chrono::seconds(2));
  }
}

}  // namespace

CellOutcome run_cell(const fs::path& out, const SuiteCell& cell, int threads) {
  const auto start = std::chrono::steady_clock::now();
  CellOutcome outcome;
  const fs::path dir = cell_dir(out, cell);
  const CellLock lock(dir);
  if (!lock.held()) {
    outcome.status = CellOutcome::Status::kBusy;
    return outcome;
  }
  std::string damage;
  if (auto result = read_result(dir, cell, &damage)) {
    outcome.status = CellOutcome::Status::kAlreadyDone;
    outcome.result = *result;
    return outcome;
  }
  if (!damage.empty()) {
    std::printf("suite: %s: %s; redoing the cell\n", cell.name.c_str(), damage.c_str());
    std::fflush(stdout);
    clear_cell(dir);
  }
  // A run folder of another run config (edited by hand, or a half-written config.json) is not resumed.
  if (fs::exists(dir / run_files::kConfig)) {
    bool same = false;
    try {
      same = same_run_config(read_json_file((dir / run_files::kConfig).string()), cell.request);
    } catch (const std::exception&) {
    }
    if (!same) {
      std::printf("suite: %s: its run folder holds another or a damaged config.json; redoing the cell\n",
                  cell.name.c_str());
      std::fflush(stdout);
      clear_cell(dir);
    }
  }
  remove_temporaries(dir);
  // This attempt supersedes an earlier one's failure (a transfer cell waiting on this one must not read it).
  fs::remove(dir / suite_files::kError);
  if (const std::string waiting = wait_for_source(dir, cell); !waiting.empty()) {
    // Recorded like any failure, so that status and the report count the cell as failed and say why.
    write_json_file((dir / suite_files::kError).string(),
                    {{"stage", "source"}, {"error", waiting}, {"host", host_name()}, {"time", utc_now()}});
    outcome.status = CellOutcome::Status::kFailed;
    outcome.error = waiting;
    return outcome;
  }
  double seconds = 0.0;
  Attempt attempt = attempt_cell(dir, cell, threads, seconds);
  if (attempt.unreadable_state) {
    std::printf("suite: %s: resuming failed (%s); redoing the cell from nothing\n", cell.name.c_str(),
                attempt.error.c_str());
    std::fflush(stdout);
    clear_cell(dir);
    attempt = attempt_cell(dir, cell, threads, seconds);
  }
  outcome.seconds = seconds_since(start);
  if (!attempt.error.empty()) {
    outcome.status = CellOutcome::Status::kFailed;
    outcome.error = attempt.error;
    return outcome;
  }
  outcome.status = CellOutcome::Status::kFinished;
  outcome.result = read_json_file((dir / suite_files::kResult).string());
  return outcome;
}

}  // namespace maps::experiments
