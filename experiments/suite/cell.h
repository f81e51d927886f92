#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "experiments/suite/config.h"

// One cell of a suite: its training and evaluation as child processes, its result.json, its error.json.
namespace maps::experiments {

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

}  // namespace maps::experiments
