#pragma once

#include <string>

namespace maps::experiments {

// `maps train --config C.json --out DIR`: trains one method on one demo file (resuming when DIR holds a run of the
// same config) and writes the run folder (experiments/run_folder.h).
struct TrainRunOptions {
  std::string config_path;
  std::string out;
};

int run_train(const TrainRunOptions& options);

}  // namespace maps::experiments
