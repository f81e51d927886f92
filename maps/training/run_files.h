#pragma once

#include <cstdint>
#include <string>

// Every file a run folder holds, named once. The trainer (this layer) writes the checkpoints and the curve; the tool
// (experiments/run/) writes the config, the provenance, the summaries and the log; a suite's cell folder adds the files
// of experiments/suite/folder.h.
namespace maps::core::run_files {

inline constexpr char kRequest[] = "request.json";        // the run config as asked for (a suite cell's, a transfer's)
inline constexpr char kConfig[] = "config.json";          // the resolved run config
inline constexpr char kProvenance[] = "provenance.json";  // one record per `maps train` process that wrote the folder
inline constexpr char kLastCheckpoint[] = "last.ckpt";    // what resuming needs (policy, Adam, step, RNG, best so far)
inline constexpr char kBestCheckpoint[] = "best.ckpt";    // the policy at its lowest validation loss
inline constexpr char kCurve[] = "curve.csv";             // one row per validation
inline constexpr char kTrainSummary[] = "train.json";     // what training came to
inline constexpr char kTrainLog[] = "train.log";          // every `maps train` process's progress, appended
inline constexpr char kEval[] = "eval.json";              // `maps eval`
inline constexpr char kEvalModules[] = "eval_modules.json";  // `maps eval --each-module`

// step_<N>.ckpt: the policy at step N (train.keep_every).
inline std::string kept_checkpoint(std::int64_t step) { return "step_" + std::to_string(step) + ".ckpt"; }

}  // namespace maps::core::run_files
