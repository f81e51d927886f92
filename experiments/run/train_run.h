#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace maps::experiments {

// `maps train --config C.json --out DIR`: trains one method on one demo file (resuming when DIR holds a run of the
// same config, extending it when only train.steps grew) and writes the run folder (experiments/run/run_folder.h), with
// train.log (what it printed) and provenance.json (who trained it from what: experiments/run/provenance.h).
struct TrainRunOptions {
  std::string config_path;
  // A config given as JSON rather than a file (Python's maps.train): config_path then only names it in messages, and
  // its relative plugin paths are taken from the working directory.
  std::optional<nlohmann::json> config;
  std::string out;
  std::vector<std::string> overrides;  // --set key=value (experiments/run/config_overrides.h)
  bool print_config = false;           // print the resolved config and stop
  // Op threads (ag::set_num_threads): 2 makes a MAPS step ~1.8x faster on 2 cores (docs/performance.md); the
  // default 1 suits grids that train two runs side by side. More threads change float rounding in the last digits.
  int threads = 1;
};

int run_train(const TrainRunOptions& options);

// What DIR already holds decides what training into it does: nothing there, or a run of the same resolved config:
// start or resume; only train.steps grew: extend (said on `log`); anything else throws, naming the keys that differ.
void check_existing_run(const std::string& out, const nlohmann::json& resolved, std::ostream& log);

}  // namespace maps::experiments
