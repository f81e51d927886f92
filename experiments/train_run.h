#pragma once

#include <string>

namespace maps::experiments {

// `maps train --config C.json --out DIR`: trains one method on one demo file (resuming when DIR holds a run of the
// same config) and writes the run folder (experiments/run_folder.h).
struct TrainRunOptions {
  std::string config_path;
  std::string out;
  // Op threads (ag::set_num_threads): 2 makes a MAPS step ~1.8x faster on 2 cores (docs/performance.md); the
  // default 1 suits grids that train two runs side by side. More threads change float rounding in the last digits.
  int threads = 1;
};

int run_train(const TrainRunOptions& options);

}  // namespace maps::experiments
