#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace maps::experiments {

// `maps collect`: rolls the committed experts of a task set out into demonstrations (envs::DemoFile, HDF5), tasks
// in parallel, with a 70/30 train/valid split by demonstration drawn within each task.
struct CollectOptions {
  std::string task_set;              // "gravity", "modified", "mt10" or a plugin's
  std::vector<std::string> plugins;  // loaded first: a plugin's task set (--plugin)
  int demos = 35;                    // kept demonstrations per task
  std::string out;                   // the .h5 file to write
  std::string actions = "mean";      // "mean" or "sample"
  std::string experts_dir;           // empty: envs::experts_dir()
  std::uint64_t first_seed = 0;      // demonstration reset seeds start here (below envs::kEvalSeedBegin)
  double min_return_fraction = 0.8;
  double train_fraction = 0.7;
  std::uint64_t split_seed = 0;
  int threads = 0;           // 0: one per core
  std::string command_line;  // recorded in the file
  bool force = false;        // replace an existing --out file
};

int run_collect(const CollectOptions& options);

}  // namespace maps::experiments
