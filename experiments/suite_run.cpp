// `maps suite run` and `maps suite prepare`: a suite's cells as child processes of this binary, resumable.

#include "experiments/suite_run.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "autograd/ops.h"
#include "envs/demo_file.h"
#include "experiments/cpu_model.h"
#include "experiments/parallel_tasks.h"
#include "experiments/provenance.h"
#include "experiments/run_folder.h"
#include "experiments/suite_costs.h"
#include "experiments/suite_folder.h"
#include "experiments/training_attempts.h"
#include "io/json_input.h"

namespace maps::experiments {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int default_jobs(int threads) {
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  return std::max(1, cores / std::max(1, threads));
}

// The last non-empty line of a log: what a failed child said last ("maps: error: ...").
std::string last_line(const fs::path& log) {
  std::string tail = tail_of(log, 5);
  while (!tail.empty() && (tail.back() == '\n' || tail.back() == ' ')) tail.pop_back();
  const auto cut = tail.rfind('\n');
  return cut == std::string::npos ? tail : tail.substr(cut + 1);
}

void write_error(const fs::path& dir, const std::string& stage, int code, const fs::path& log) {
  write_json_file((dir / "error.json").string(), {{"stage", stage},
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
  if (!fs::is_directory(dir / kReplacedFolder)) return list;
  std::vector<fs::path> folders;
  for (const auto& entry : fs::directory_iterator(dir / kReplacedFolder)) folders.push_back(entry.path());
  std::sort(folders.begin(), folders.end());
  for (const auto& folder : folders) {
    Json entry{{"folder", (fs::path(kReplacedFolder) / folder.filename()).string()}};
    try {
      const Json old = read_json_file((folder / "result.json").string());
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
  write_json_file((dir / "request.json").string(), cell.request);
  const std::string thread_arg = std::to_string(threads);
  // maps train keeps its own train.log in the folder; train.out gets whatever the process printed (a crash too).
  const int train_code =
      run_self({"train", "--config", (dir / "request.json").string(), "--out", dir.string(), "--threads", thread_arg},
               dir / "train.out");
  if (train_code != 0) return failed_stage(dir, "train", train_code, dir / "train.out");
  std::vector<std::string> eval_args{"eval", "--run", dir.string(), "--threads", thread_arg};
  if (cell.request["train"].value("keep_every", 0LL) > 0) eval_args.push_back("--checkpoints");
  const int eval_code = run_self(eval_args, dir / "eval.log");
  if (eval_code != 0) return failed_stage(dir, "eval", eval_code, dir / "eval.log");
  seconds = seconds_since(start);
  Json result{{"format", kCellFormat},
              {"cell", cell.identity()},
              {"config", read_json_file((dir / "config.json").string())},
              {"train", read_json_file((dir / "train.json").string())},
              {"eval", read_json_file((dir / "eval.json").string())},
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
      finished = read_json_file((source / "result.json").string()).value("finished", Json());
    } catch (const std::exception&) {
    }
    result["source"] = {{"cell", source.filename().string()}, {"finished", finished}};
  }
  if (Json replaces = replaced_results(dir); !replaces.empty()) result["replaces"] = replaces;
  if (!same_run_config(result["config"], cell.request))
    return {"the run folder's config.json is not the cell's run config (the folder was changed while it ran)"};
  write_json_file((dir / "result.json").string(), result);
  fs::remove(dir / "error.json");
  return {};
}

}  // namespace

int run_program(const std::string& program, const std::vector<std::string>& args, const fs::path* log) {
  // Everything the child needs is made before fork: between fork and exec only async-signal-safe calls.
  std::vector<std::string> full{program == "/proc/self/exe" ? "maps" : fs::path(program).filename().string()};
  full.insert(full.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& arg : full) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const std::string log_path = log ? log->string() : "";
  const pid_t parent = ::getpid();
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(126);  // the parent died before prctl
    if (!log_path.empty()) {
      const int fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
      if (fd < 0) ::_exit(125);
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
    }
    ::execv(program.c_str(), argv.data());
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw std::runtime_error(std::string("waitpid failed: ") + std::strerror(errno));
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

int run_self(const std::vector<std::string>& args, const fs::path& log) {
  return run_program("/proc/self/exe", args, &log);
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
    if (fs::exists(source / "result.json")) {
      const fs::path checkpoint = source_checkpoint(dir, cell);
      if (fs::exists(checkpoint)) return "";
      return "its source cell " + source.string() + " is finished but its " + checkpoint.filename().string() +
             " is gone (checkpoints are not kept with the results): rerun the suite, "
             "which trains it again, with every cell that starts from it, before the others";
    }
    // A running source is waited for even when an error.json of an earlier attempt is still there; a worker that
    // has just taken the source may not hold its lock (nor have cleared that error.json) yet: allow it a moment
    // (a few seconds when the source has failed, so that a failed source's dependants do not each wait long).
    const bool failed = fs::exists(source / "error.json");
    if (!cell_is_locked(source) && seconds_since(start) > (failed ? 5.0 : 30.0)) {
      // It may have finished between the checks above (writing result.json, then releasing its lock).
      if (fs::exists(source / "result.json")) continue;  // checked at the top
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
  if (fs::exists(dir / "config.json")) {
    bool same = false;
    try {
      same = same_run_config(read_json_file((dir / "config.json").string()), cell.request);
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
  fs::remove(dir / "error.json");
  if (const std::string waiting = wait_for_source(dir, cell); !waiting.empty()) {
    // Recorded like any failure, so that status and the report count the cell as failed and say why.
    write_json_file((dir / "error.json").string(),
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
  outcome.result = read_json_file((dir / "result.json").string());
  return outcome;
}

void ensure_demo_files(const Suite& suite, const std::vector<const SuiteCell*>& cells, int threads) {
  std::set<std::string> sets;
  for (const auto* cell : cells) sets.insert(cell->set);
  for (const auto& name : sets) {
    const SuiteSet& set = suite.sets.at(name);
    const fs::path file(set.demo_file);
    if (fs::exists(file)) {
      const envs::DemoFile demos = envs::read_demo_file(file.string());
      if (demos.task_set != name)
        throw std::runtime_error(file.string() + " holds task set '" + demos.task_set + "', but the suite's set '" +
                                 name + "' names it (sets." + name + ".data.file)");
      continue;
    }
    if (!file.parent_path().empty()) fs::create_directories(file.parent_path());
    const fs::path partial = file.string() + "." + host_name() + "." + std::to_string(::getpid()) + ".partial.h5";
    const fs::path log = file.string() + ".collect.log";
    std::printf("suite: collecting %s (%s, %d demos per task; log %s)\n", file.string().c_str(), name.c_str(),
                set.collect_demos, log.string().c_str());
    std::fflush(stdout);
    const auto start = std::chrono::steady_clock::now();
    const int code = run_self({"collect", "--set", name, "--demos", std::to_string(set.collect_demos), "--out",
                               partial.string(), "--threads", std::to_string(threads)},
                              log);
    if (code != 0) {
      fs::remove(partial);
      throw std::runtime_error("collecting " + file.string() + " failed (exit " + std::to_string(code) +
                               "): " + last_line(log));
    }
    fs::rename(partial, file);
    std::printf("suite: wrote %s in %.0f s\n", file.string().c_str(), seconds_since(start));
    std::fflush(stdout);
  }
}

int run_suite_prepare(const std::string& config_path, int threads) {
  const Suite suite = load_suite(config_path);
  std::vector<const SuiteCell*> all;
  for (const auto& cell : suite.cells) all.push_back(&cell);
  ensure_demo_files(suite, all, threads);
  std::printf("suite: the demonstration files of %s are in place\n", config_path.c_str());
  return 0;
}

int run_suite(const SuiteRunOptions& options) {
  const Suite suite = load_suite(options.config_path);
  const auto [shard, shards] = parse_shard(options.shard);
  const std::vector<const SuiteCell*> cells = shard_cells(suite, shard, shards);
  const fs::path out(options.out);
  write_or_check_manifest(out, suite);
  const auto costs = try_load_costs(options.costs);
  auto estimate = [&costs](const SuiteCell& cell) -> std::optional<double> {
    try {
      if (costs) return costs->cell_seconds(cell);
    } catch (const std::exception&) {
    }
    return std::nullopt;
  };

  const std::set<fs::path> held_elsewhere = retire_sources_without_checkpoint(out, cells);

  // What is left, and its estimated CPU time.
  std::vector<const SuiteCell*> left;
  double estimate_left = 0.0;
  bool estimated = costs.has_value();
  std::size_t held = 0;  // of a group to run again that another process holds: not run here, not finished either
  // Each cell after the cell its init.run names (a hand-written suite may list them the other way), so that a job
  // never waits for a source no job has taken.
  const std::set<const SuiteCell*> in_shard(cells.begin(), cells.end());
  for (const auto* cell : sources_first(suite)) {
    if (!in_shard.count(cell)) continue;
    if (held_elsewhere.count(cell_dir(out, *cell).lexically_normal())) {
      ++held;
      continue;
    }
    if (read_result(cell_dir(out, *cell), *cell)) continue;
    left.push_back(cell);
    const auto seconds = estimate(*cell);
    estimated = estimated && seconds.has_value();
    estimate_left += seconds.value_or(0.0);
  }
  const int jobs = std::clamp(options.jobs > 0 ? options.jobs : default_jobs(options.threads), 1,
                              std::max(1, static_cast<int>(left.size())));
  std::printf("suite: %s, shard %d/%d: %zu cells, %zu finished before, %zu to run on %d jobs x %d threads",
              options.config_path.c_str(), shard, shards, cells.size(), cells.size() - left.size() - held, left.size(),
              jobs, options.threads);
  if (held > 0) std::printf(", %zu left to another process", held);
  if (estimated)
    std::printf(" (estimated %s of CPU, %s of wall)", format_duration(estimate_left).c_str(),
                format_duration(estimate_left / jobs).c_str());
  std::printf(" -> %s\n", out.string().c_str());
  std::fflush(stdout);
  auto held_message = [held] {
    std::printf("suite: %zu cells of sources to run again were held by another process: rerun once it has stopped\n",
                held);
    return 3;
  };
  if (left.empty()) return held > 0 ? held_message() : 0;
  ensure_demo_files(suite, left, std::max(1, jobs * options.threads));

  std::mutex mutex;
  std::size_t done = 0, failed = 0, busy = 0;
  // The ETA scales the estimate of what is left by how the cells finished here went against theirs (wall time
  // over estimated CPU time, so it already counts the jobs running side by side).
  double estimate_finished = 0.0;
  const auto start = std::chrono::steady_clock::now();
  auto report = [&](const SuiteCell& cell, const CellOutcome& outcome) {
    std::string line;
    switch (outcome.status) {
      case CellOutcome::Status::kFinished:
      case CellOutcome::Status::kAlreadyDone: {
        ++done;
        char text[256];
        std::snprintf(text, sizeof(text), "mean score %.3f, best step %lld of %lld, ",
                      outcome.result["eval"]["mean_score"].get<double>(),
                      outcome.result["eval"]["best_step"].get<long long>(),
                      outcome.result["train"]["steps"].get<long long>());
        line = text;
        line += outcome.status == CellOutcome::Status::kAlreadyDone ? "finished by another process"
                                                                    : format_duration(outcome.seconds);
        break;
      }
      case CellOutcome::Status::kBusy:
        ++busy;
        line = "running in another process (its .lock is held); skipped";
        break;
      case CellOutcome::Status::kFailed:
        ++failed;
        line = "FAILED: " + outcome.error;
        break;
    }
    std::printf("[%zu/%zu] %s: %s\n", done + failed + busy, left.size(), cell.name.c_str(), line.c_str());
    estimate_left -= estimate(cell).value_or(0.0);
    if (outcome.status == CellOutcome::Status::kFinished) estimate_finished += estimate(cell).value_or(0.0);
    const double elapsed = seconds_since(start);
    const std::size_t remaining = left.size() - done - failed - busy;
    std::string eta = remaining == 0 ? "0s" : "unknown";
    if (remaining > 0 && estimated && estimate_finished > 0.0)
      eta = format_duration(std::max(0.0, estimate_left) * elapsed / estimate_finished);
    std::printf("suite: %zu of %zu done, %zu failed, %zu elsewhere, %zu left; elapsed %s, ETA %s\n", done, left.size(),
                failed, busy, remaining, format_duration(elapsed).c_str(), eta.c_str());
    std::fflush(stdout);
  };
  run_tasks_in_parallel(left.size(), jobs, [&](std::size_t i) {
    const SuiteCell& cell = *left[i];
    CellOutcome outcome;
    try {
      outcome = run_cell(out, cell, options.threads);
    } catch (const std::exception& e) {
      outcome.status = CellOutcome::Status::kFailed;
      outcome.error = e.what();
    }
    const std::lock_guard<std::mutex> guard(mutex);
    report(cell, outcome);
  });
  std::printf("suite: shard %d/%d finished: %zu cells done, %zu failed, %zu running elsewhere (maps suite status %s)\n",
              shard, shards, done, failed, busy, out.string().c_str());
  if (failed > 0) return 1;
  if (busy > 0) {
    std::printf("suite: %zu cells were running in another process: rerun once it has stopped to see them finished\n",
                busy);
    return 3;
  }
  if (held > 0) return held_message();
  return 0;
}

}  // namespace maps::experiments
