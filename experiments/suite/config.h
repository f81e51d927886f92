#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

// A comparison suite (experiments/suites/*.json): named grids, each a product of axes (set x method x variant x
// demos x seed), expanded into cells in a fixed order. Strict JSON: an unknown key is an error naming it.
//
//   {"description": "...",
//    "defaults": {<partial run config under every cell, e.g. "train": {"steps": 20000}, "eval": {"episodes": 100}>},
//    "sets": {"gravity": {"data": {"file": "data/gravity.h5", "collect_demos": 35, "subsample": 10},
//                         "demos": [5, 10, 15, 25],           // the set's demo counts when a grid names none
//                         "config": {<partial run config for this set: batch, selector weights, MAML query>}}},
//    "variants": {"no_share": {"maps": {"selector_losses": {"share": 0}}}},   // partial run configs
//    "grids": [{"name": "comparison", "sets": ["gravity"], "methods": ["maps", "mt_bc"],
//               "variants": ["base"],                          // optional; "base" is the run without a variant
//               "demos": [5, 10] or {"gravity": [5, 10]},      // optional; default: each set's "demos"
//               "seeds": [0, 1, 2]}]}
//
// A cell's run config is defaults, then the set's config, then its data (file, subsample), then the variant, then
// the cell's own method, seed and demos per task, each merged key by key over the one before (objects recursively).
namespace maps::experiments {

struct SuiteSet {
  std::string name;  // gravity, modified or mt10
  std::string demo_file;
  int collect_demos = 35;  // demonstrations per task when the suite collects the file
  int subsample = 1;
  std::vector<int> demos;
  nlohmann::json config = nlohmann::json::object();
};

struct SuiteCell {
  int index = 0;     // position in the expanded suite; --shard i/N runs shard_key % N == i
  std::string name;  // "<set>/<method>[-<variant>]_d<demos>_s<seed>": the cell's folder under cells/
  std::string grid;  // the first grid that named it
  std::string set, method, variant;
  int demos = 0, subsample = 1;
  std::uint64_t seed = 0;
  nlohmann::json request;  // the resolved run config (core::to_json), what `maps train --config` gets

  // index, name, grid, set, method, variant, demos, subsample, seed (no request).
  nlohmann::json identity() const;
};

struct Suite {
  std::string path;                      // the config file it was read from ("" when parsed from JSON)
  nlohmann::json source;                 // the config as written
  std::map<std::string, SuiteSet> sets;  // every set the config defines
  std::vector<SuiteCell> cells;          // expanded, duplicates removed, in the fixed order
};

// Recursive merge: objects key by key, anything else replaced.
nlohmann::json merge_json(nlohmann::json base, const nlohmann::json& more);

// Expands and checks the config: every grid's names exist, every cell's run config parses
// (core::parse_run_config), and a cell named twice (by two grids) gets the same run config both times. Order:
// grids as listed; within a grid, seeds outermost, then sets, methods, variants and demos as listed (so the first
// seed of every cell finishes before the second starts).
Suite parse_suite(const nlohmann::json& json, const std::string& where);
// precision (train.precision: "float32" or "bf16"; "" : as the file says) is set in the suite's defaults, so every
// cell whose set config or variant does not set it trains so: `maps suite plan|run --precision` (issue 44).
Suite load_suite(const std::string& path, const std::string& precision = "");
// The cell of the suite that `cell` starts from (init.run "../<name>", a sibling in its set); nullptr when none.
const SuiteCell* source_cell(const Suite& suite, const SuiteCell& cell);

// "i/N" -> {i, N}, with 0 <= i < N; throws naming the text otherwise.
std::pair<int, int> parse_shard(const std::string& text);
// A cell's index, or for a transfer cell its source's (the shard that runs the source runs the transfer too).
int shard_key(const Suite& suite, const SuiteCell& cell);
// The cells with shard_key % shards == shard, in order.
std::vector<const SuiteCell*> shard_cells(const Suite& suite, int shard, int shards);

}  // namespace maps::experiments
