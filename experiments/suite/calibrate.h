#pragma once

#include <string>
#include <vector>

namespace maps::experiments {

// `maps suite calibrate [--out F] [--steps S] [--episodes E] [--sets ...]`: trains and evaluates every method on
// every set briefly, timing each, and writes the cost table.
struct SuiteCalibrateOptions {
  std::string out;  // "" : default_costs_path()
  std::string work = "runs/calibrate";
  int steps = 400;
  int episodes = 2;
  std::vector<std::string> sets;  // empty: every set (envs::task_set_names())
};
int run_suite_calibrate(const SuiteCalibrateOptions& options);

}  // namespace maps::experiments
