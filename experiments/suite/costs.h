#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "experiments/suite/config.h"

// Measured costs of training and evaluation (experiments/suites/costs.json, written by `maps suite calibrate`),
// and the estimate of a cell's CPU time they give:
//   seconds = overhead + steps * step_seconds * (rows / measured rows) [* modules / measured modules, for MAPS]
//             + validations * validation_seconds [* the same model scale * validation states / measured ones]
//             + checkpoint writes * checkpoint_seconds
//             + episodes * tasks * episode_seconds
// with rows = states_per_task (MAML: states_per_task + query_per_task), and step_seconds_bf16 for a cell with
// train.precision "bf16". A GAIL cell ("imitation": "gail"):
//   seconds = overhead + env_steps_per_task * tasks * gail_env_step_seconds
//             + warm-up iterations * (warm-up updates - updates) * gail_discriminator_update_seconds
//             + episodes * tasks * episode_seconds
// (calibrated at the default gail settings: `maps suite calibrate --gail-env-steps N`).
// Per-step cost grows about linearly in the batch and (for MAPS) in the module count at these shapes. Tables
// calibrated before validation and checkpoints were timed apart (2026-12-02) have neither field: their
// step_seconds holds validation at the measured validate_every, and both terms count zero. An estimate, not a
// promise: `maps suite run` prints how the real times compare.
namespace maps::experiments {

struct CostTable {
  nlohmann::json json;  // {"sets": {set: {"collect_seconds": s, "methods": {method: {...}}}}, "cpu": ..., ...}
  std::string path;

  // One thread per cell, in parts: a part-trained cell has its training part left, all of the rest.
  struct CellCost {
    double overhead = 0.0, training = 0.0, evaluation = 0.0;
    // Of training: scoring the validation states, and writing checkpoints (best.ckpt counted at every
    // validation: an upper bound, as it is written only when the validation loss improves).
    double validation = 0.0, checkpointing = 0.0;
    // Empty, or the entry whose measured cost stood in for the cell's unmeasured one ("maps", or for a choice of a
    // method's cost option the method's entry without one, "diffusion_policy").
    std::string estimated_as;
    // The entry the cell asks for ("mt_bc", "diffusion_policy/mlp"), measured or not.
    std::string key;
    // The CPU the entry used was timed on (its own "cpu", else the table's).
    std::string cpu;
    // A GAIL cell whose policy's size differs from the measured one, priced at the measured size because the entry
    // has no policy part (gail_policy_env_step_seconds: timed before it was recorded).
    bool size_unpriced = false;
    double total() const { return overhead + training + evaluation; }
  };
  // Throws naming the set and method when the table lacks them.
  CellCost cell_cost(const SuiteCell& cell) const;
  double cell_seconds(const SuiteCell& cell) const { return cell_cost(cell).total(); }
  double collect_seconds(const std::string& set) const;
};

// A cost table's key for a method, or for one choice of its cost option ("diffusion_policy/mlp").
std::string cost_key(const std::string& method, const std::string& choice = "");
// The CPU a cost entry or a whole table names (its "cpu"), or "an unnamed CPU" when it names none.
std::string recorded_cpu(const nlohmann::json& holder);

// experiments/suites/costs.json of the source tree (override: MAPS_SUITES_DIR) when `path` is empty.
std::filesystem::path default_costs_path();
CostTable load_costs(const std::string& path);
// Like load_costs, but std::nullopt when the file is missing or damaged (saying why on stderr unless quiet).
std::optional<CostTable> try_load_costs(const std::string& path, bool quiet = false);

// "1h02m", "3m05s", "12s".
std::string format_duration(double seconds);

}  // namespace maps::experiments
