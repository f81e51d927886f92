#pragma once
// The run config's keys, each declared once: its type, range, default and meaning, and where it lives in
// RunConfig. parse_run_config reads and checks through it, to_json writes through it, docs/configs.md's table of
// keys is printed from it (`maps schema run-config --markdown`) and tests try every key with the edge values of
// its type.

#include <functional>
#include <nlohmann/json.hpp>
#include <vector>

#include "io/config_schema.h"
#include "maps/training/run_config.h"

namespace maps::core {

struct RunConfigField {
  io::Field spec;
  std::function<nlohmann::json(const RunConfig&)> get;
  std::function<void(RunConfig&, const nlohmann::json&)> set;  // a value check_value accepted
  // Choices that grow as plugins register entries (the method's): read when a config is checked, not when the table
  // was built. Empty: spec.choices is all there is.
  std::function<std::vector<std::string>()> current_choices;

  // The spec as a value is checked against now (current_choices filled in).
  io::Field current_spec() const;
};

// Every key but the methods' own sections, in the docs' order (top-level keys, then data, train, maps, maml,
// baselines, eval, init).
const std::vector<RunConfigField>& run_config_fields();

// Every key a run config can hold, the registered methods' sections included ("moore.experts", after
// baselines.hidden), in the docs' order.
std::vector<io::Field> run_config_schema();

}  // namespace maps::core
