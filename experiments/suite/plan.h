#pragma once

#include <string>

namespace maps::experiments {

// `maps suite plan C.json [--shard i/N] [--jobs N] [--cells] [--json] [--costs F]`.
struct SuitePlanOptions {
  std::string config_path;
  std::string shard = "0/1";
  int jobs = 0;
  bool list_cells = false;
  bool json = false;
  std::string costs;
  std::string precision;  // "" : as the config says; else every cell's train.precision (load_suite)
};
int run_suite_plan(const SuitePlanOptions& options);

}  // namespace maps::experiments
