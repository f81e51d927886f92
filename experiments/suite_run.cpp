// `maps suite run` and `maps suite prepare`: a suite's cells as child processes of this binary, resumable.

#include "experiments/suite_run.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>

#include "envs/demo_file.h"
#include "experiments/run_folder.h"
#include "experiments/suite_costs.h"
#include "experiments/suite_folder.h"

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

// One attempt: train (resuming), evaluate, write result.json. "" on success, else the failure.
std::string attempt_cell(const fs::path& dir, const SuiteCell& cell, int threads, double& seconds) {
  const auto start = std::chrono::steady_clock::now();
  write_json_file((dir / "request.json").string(), cell.request);
  const std::string thread_arg = std::to_string(threads);
  const int train_code =
      run_self({"train", "--config", (dir / "request.json").string(), "--out", dir.string(), "--threads", thread_arg},
               dir / "train.log");
  if (train_code != 0) {
    write_error(dir, "train", train_code, dir / "train.log");
    return "training failed (exit " + std::to_string(train_code) + "): " + last_line(dir / "train.log");
  }
  const int eval_code = run_self({"eval", "--run", dir.string(), "--threads", thread_arg}, dir / "eval.log");
  if (eval_code != 0) {
    write_error(dir, "eval", eval_code, dir / "eval.log");
    return "evaluation failed (exit " + std::to_string(eval_code) + "): " + last_line(dir / "eval.log");
  }
  seconds = seconds_since(start);
  Json result{{"format", kCellFormat},
              {"cell", cell.identity()},
              {"config", read_json_file((dir / "config.json").string())},
              {"train", read_json_file((dir / "train.json").string())},
              {"eval", read_json_file((dir / "eval.json").string())},
              {"wall_seconds", seconds},
              {"threads", threads},
              {"host", host_name()},
              {"finished", utc_now()}};
  if (result["config"] != cell.request)
    return "the run folder's config.json is not the cell's run config (the folder was changed while it ran)";
  write_json_file((dir / "result.json").string(), result);
  fs::remove(dir / "error.json");
  return "";
}

}  // namespace

int run_self(const std::vector<std::string>& args, const fs::path& log) {
  // Everything the child needs is made before fork: between fork and exec only async-signal-safe calls.
  std::vector<std::string> full{"maps"};
  full.insert(full.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& arg : full) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const std::string log_path = log.string();
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (pid == 0) {
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(126);  // the parent died before prctl
    const int fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd < 0) ::_exit(125);
    ::dup2(fd, STDOUT_FILENO);
    ::dup2(fd, STDERR_FILENO);
    ::close(fd);
    ::execv("/proc/self/exe", argv.data());
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) throw std::runtime_error(std::string("waitpid failed: ") + std::strerror(errno));
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
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
      same = read_json_file((dir / "config.json").string()) == cell.request;
    } catch (const std::exception&) {
    }
    if (!same) {
      std::printf("suite: %s: its run folder holds another or a damaged config.json; redoing the cell\n",
                  cell.name.c_str());
      std::fflush(stdout);
      clear_cell(dir);
    }
  }
  const bool had_state = fs::exists(dir / "last.ckpt") || fs::exists(dir / "best.ckpt");
  double seconds = 0.0;
  std::string error = attempt_cell(dir, cell, threads, seconds);
  if (!error.empty() && had_state) {
    std::printf("suite: %s: resuming failed (%s); redoing the cell from nothing\n", cell.name.c_str(), error.c_str());
    std::fflush(stdout);
    clear_cell(dir);
    error = attempt_cell(dir, cell, threads, seconds);
  }
  outcome.seconds = seconds_since(start);
  if (!error.empty()) {
    outcome.status = CellOutcome::Status::kFailed;
    outcome.error = error;
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
  const int jobs = std::clamp(options.jobs > 0 ? options.jobs : default_jobs(options.threads), 1,
                              std::max(1, static_cast<int>(cells.size())));
  const auto costs = try_load_costs(options.costs);

  // What is left, and its estimated CPU time.
  std::vector<const SuiteCell*> left;
  double estimate_left = 0.0;
  bool estimated = costs.has_value();
  for (const auto* cell : cells) {
    if (read_result(cell_dir(out, *cell), *cell)) continue;
    left.push_back(cell);
    if (estimated) {
      try {
        estimate_left += costs->cell_seconds(*cell);
      } catch (const std::exception&) {
        estimated = false;
      }
    }
  }
  std::printf("suite: %s, shard %d/%d: %zu cells, %zu finished before, %zu to run on %d jobs x %d threads",
              options.config_path.c_str(), shard, shards, cells.size(), cells.size() - left.size(), left.size(), jobs,
              options.threads);
  if (estimated)
    std::printf(" (estimated %s of CPU, %s of wall)", format_duration(estimate_left).c_str(),
                format_duration(estimate_left / jobs).c_str());
  std::printf(" -> %s\n", out.string().c_str());
  std::fflush(stdout);
  if (left.empty()) return 0;
  ensure_demo_files(suite, left, std::max(1, jobs * options.threads));

  std::mutex mutex;
  std::atomic<std::size_t> next{0};
  std::size_t done = 0, failed = 0, busy = 0;
  double estimate_done = 0.0;
  const auto start = std::chrono::steady_clock::now();
  auto worker = [&] {
    for (std::size_t i = next++; i < left.size(); i = next++) {
      const SuiteCell& cell = *left[i];
      CellOutcome outcome;
      try {
        outcome = run_cell(out, cell, options.threads);
      } catch (const std::exception& e) {
        outcome.status = CellOutcome::Status::kFailed;
        outcome.error = e.what();
      }
      const std::lock_guard<std::mutex> guard(mutex);
      char line[512];
      switch (outcome.status) {
        case CellOutcome::Status::kFinished:
        case CellOutcome::Status::kAlreadyDone: {
          ++done;
          const Json& eval = outcome.result["eval"];
          std::snprintf(line, sizeof(line), "mean score %.3f, best step %lld of %lld, %s",
                        eval.value("mean_score", 0.0), static_cast<long long>(eval.value("best_step", -1LL)),
                        static_cast<long long>(outcome.result["train"].value("steps", 0LL)),
                        outcome.status == CellOutcome::Status::kAlreadyDone ? "finished by another process"
                                                                            : format_duration(outcome.seconds).c_str());
          break;
        }
        case CellOutcome::Status::kBusy:
          ++busy;
          std::snprintf(line, sizeof(line), "running in another process (its .lock is held); skipped");
          break;
        case CellOutcome::Status::kFailed:
          ++failed;
          std::snprintf(line, sizeof(line), "FAILED: %s", outcome.error.c_str());
          break;
      }
      std::printf("[%zu/%zu] %s: %s\n", done + failed + busy, left.size(), cell.name.c_str(), line);
      if (estimated) {
        try {
          estimate_done += costs->cell_seconds(cell);
        } catch (const std::exception&) {
        }
      }
      const double elapsed = seconds_since(start);
      const std::size_t remaining = left.size() - done - failed - busy;
      std::string eta = "unknown";
      if (estimated && estimate_done > 0.0)
        eta = format_duration(std::max(0.0, estimate_left - estimate_done) * elapsed / estimate_done);
      std::printf("suite: %zu of %zu done, %zu failed, %zu elsewhere, %zu left; elapsed %s, ETA %s\n", done,
                  left.size(), failed, busy, remaining, format_duration(elapsed).c_str(),
                  remaining == 0 ? "0s" : eta.c_str());
      std::fflush(stdout);
    }
  };
  std::vector<std::thread> pool;
  for (int j = 0; j < jobs; ++j) pool.emplace_back(worker);
  for (auto& thread : pool) thread.join();
  std::printf("suite: shard %d/%d finished: %zu cells done, %zu failed, %zu running elsewhere (maps suite status %s)\n",
              shard, shards, done, failed, busy, out.string().c_str());
  return failed > 0 ? 1 : 0;
}

}  // namespace maps::experiments
