#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>

namespace maps::experiments {

// Where each `maps train` process that trained the run folder `dir` ran, from DIR/provenance.json (which is not kept
// with the results): training's CPU time in curve.csv spans them all, and their CPUs may differ. One object per
// process with whichever of "started_utc", "git_commit", "cpu", "float32_gemm_kernel", "matmul_precision",
// "threads", "start_step", "steps" its record has. A process that started at its target step trained nothing (a rerun
// after a kill during evaluation) and is left out; records from before "start_step" was recorded are kept. [] without
// the file; a single
// {"error": ...} when it cannot be read, so that a result is never lost to its provenance.
nlohmann::json training_attempts(const std::filesystem::path& dir);

}  // namespace maps::experiments
