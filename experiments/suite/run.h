#pragma once

#include <string>

namespace maps::experiments {

// `maps suite run C.json --out DIR [--jobs N] [--shard i/N] [--threads T]`.
struct SuiteRunOptions {
  std::string config_path;
  std::string out;
  int jobs = 0;     // cells at once (0: cores / threads)
  int threads = 1;  // op threads of each cell's training and evaluation
  std::string shard = "0/1";
  std::string costs;      // cost table for the ETA ("" : experiments/suites/costs.json of the source tree)
  std::string precision;  // "" : as the config says; else every cell's train.precision (load_suite)
};
int run_suite(const SuiteRunOptions& options);

}  // namespace maps::experiments
