#pragma once

#include <string>
#include <vector>

#include "experiments/suite/config.h"

// The demonstration files a suite's sets name, collected when missing.
namespace maps::experiments {

// Collects the demo files of `cells`' sets that are missing (maps collect into a file named for this host and
// process, then renamed: shards collecting at once cannot see half a file), and checks that existing ones hold
// the right task set. Progress goes to stdout.
void ensure_demo_files(const Suite& suite, const std::vector<const SuiteCell*>& cells, int threads);

// `maps suite prepare C.json`: collects every missing demonstration file of the suite's sets.
int run_suite_prepare(const std::string& config_path, int threads);

}  // namespace maps::experiments
