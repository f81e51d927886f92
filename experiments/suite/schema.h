#pragma once
// The suite config's keys (experiments/suites/*.json, docs/suite.md), each with its type, range and meaning:
// parse_suite checks every value through this table, `maps schema suite-config` prints it, and a test tries every
// key with the edge values of its type. A key names its place with "<set>" (a task set's name), "<variant>" (a
// variant's name) and "grids[]" (every grid).

#include <string>
#include <vector>

#include "io/config_schema.h"

namespace maps::experiments {

const std::vector<io::Field>& suite_config_schema();

// The field of a key of the table ("grids[].seeds"); a key not in it is a programming error (std::logic_error).
io::Field suite_field(const std::string& key);

}  // namespace maps::experiments
