// `maps suite run`: a suite's cells as child processes of this binary, resumable.

#include "experiments/suite/run.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <optional>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "autograd/matmul_precision.h"
#include "experiments/process/host.h"
#include "experiments/process/parallel_tasks.h"
#include "experiments/suite/cell.h"
#include "experiments/suite/costs.h"
#include "experiments/suite/demo_files.h"
#include "experiments/suite/folder.h"

namespace maps::experiments {

namespace fs = std::filesystem;

namespace {

int default_jobs(int threads) {
  const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  return std::max(1, cores / std::max(1, threads));
}

}  // namespace

int run_suite(const SuiteRunOptions& options) {
  const Suite suite = load_suite(options.config_path, options.precision);
  const auto [shard, shards] = parse_shard(options.shard);
  const std::vector<const SuiteCell*> cells = shard_cells(suite, shard, shards);
  // bf16 cells on a CPU without the instructions: refused here, before any cell starts, rather than each failing.
  for (const auto* cell : cells) {
    const std::string precision = cell->request["train"].value("precision", std::string("float32"));
    const std::string refusal = ag::matmul_precision_refusal(ag::parse_matmul_precision(precision));
    if (!refusal.empty())
      throw std::invalid_argument(options.config_path + ": cell " + cell->name + ": train.precision \"bf16\" " +
                                  refusal + " (use float32 here: --precision float32 sets it in the suite's defaults)");
  }
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
