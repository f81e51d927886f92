#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "experiments/suite_config.h"

namespace maps::experiments {

// `maps suite run C.json --out DIR [--jobs N] [--shard i/N] [--threads T]`.
struct SuiteRunOptions {
  std::string config_path;
  std::string out;
  int jobs = 0;     // cells at once (0: cores / threads)
  int threads = 1;  // op threads of each cell's training and evaluation
  std::string shard = "0/1";
  std::string costs;  // cost table for the ETA ("" : experiments/suites/costs.json of the source tree)
};
int run_suite(const SuiteRunOptions& options);

// `maps suite prepare C.json`: collects every missing demonstration file of the suite's sets.
int run_suite_prepare(const std::string& config_path, int threads);

// What running one cell came to.
struct CellOutcome {
  enum class Status { kFinished, kAlreadyDone, kBusy, kFailed } status = Status::kFailed;
  nlohmann::json result;  // kFinished / kAlreadyDone
  std::string error;      // kFailed
  double seconds = 0.0;   // wall time of this call
};

// Trains (resuming from the cell folder's checkpoint) and evaluates one cell as child processes of this binary,
// under the cell's lock, and writes result.json atomically. A cell folder whose resumed run fails (damaged
// checkpoint or run folder) is cleared and redone once from nothing before the failure is recorded in error.json.
CellOutcome run_cell(const std::filesystem::path& out, const SuiteCell& cell, int threads);

// Collects the demo files of `cells`' sets that are missing (maps collect into a file named for this host and
// process, then renamed: shards collecting at once cannot see half a file), and checks that existing ones hold
// the right task set. Progress goes to stdout.
void ensure_demo_files(const Suite& suite, const std::vector<const SuiteCell*>& cells, int threads);

// Runs `program` (a path) with `args`, its stdout and stderr appended to `log` (nullptr: this process's); the
// child is killed when the calling thread dies. Returns the exit code (128 + signal when killed by one; 127 when
// it could not be started).
int run_program(const std::string& program, const std::vector<std::string>& args, const std::filesystem::path* log);
// run_program on this binary (/proc/self/exe: the same build for the whole suite, even if build/ is rebuilt).
int run_self(const std::vector<std::string>& args, const std::filesystem::path& log);

}  // namespace maps::experiments
