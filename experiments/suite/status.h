#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace maps::experiments {

// `maps suite status DIR... [--json] [--all]`: each cell of DIR/suite.json is done (a trusted result.json), running
// (its .lock is held), failed (error.json, with the error), started (a checkpoint to resume from) or left. Several
// folders of one suite (the shard folders of a cluster run) are read as one: a cell counts as what its most
// advanced folder says (done, then running, failed, started, left).
struct SuiteStatusOptions {
  std::vector<std::string> dirs;
  bool json = false;
  bool all = false;  // one line per cell, not only failed and running ones
};
int run_suite_status(const SuiteStatusOptions& options);

// What `maps suite status --json` prints: the one place that decides what each cell is, for the tool and for the
// report (experiments/report/suite_results.py reads this, not the cell folders' files, to know which results count).
//   {"format": "maps-suite-status/1", "dirs": [...], "task_sets": [...], "counts": {state: n},
//    "cells": [{<identity>, "state": done|running|failed|started|left|dropped, "detail": text,
//               "folder": the cell folder it was read from, "damage": why its result.json does not count,
//               "error": {"stage", "error"} of a failed cell, "runs_again": true,
//               "replaced": [{"folder": an earlier run's replaced/<time>/, "damage": why it does not count}]}],
//    "cpu_seconds_left": s, ...}
inline constexpr const char* kStatusFormat = "maps-suite-status/1";
nlohmann::json suite_status(const std::vector<std::string>& dirs);

}  // namespace maps::experiments
