#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

// `--set key=value` on the command line: a dotted key into a JSON config ("train.steps=40000",
// "maps.selector_losses.share=0", "method=mt_bc"). The value is read as JSON when it parses as JSON (numbers, true,
// [128, 128], {"a": 1}), else as a string, so strings need no quotes. Intermediate objects are made when missing;
// the config's own parser then refuses a key it does not know.
namespace maps::experiments {

// Applies each "key=value" in order. Throws std::invalid_argument naming the assignment when it has no '=', an
// empty key or key part, or a key part that would go through a value that is not an object.
void apply_overrides(nlohmann::json& config, const std::vector<std::string>& assignments);

}  // namespace maps::experiments
