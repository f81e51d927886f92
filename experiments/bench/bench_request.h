#pragma once

#include <nlohmann/json.hpp>
#include <string>

// The run config a benchmark builds its method from (`maps bench step|eval --method NAME --config FILE`).
namespace maps::experiments {

// {"method": method, "data": {"file": <unused>}} over the partial run config in config_path (its plugins loaded;
// none when empty): the method at its defaults, as `maps train` would build it, with the config's changes. `who`
// names the command in errors ("bench step").
nlohmann::json bench_request(const std::string& method, const std::string& config_path, const std::string& who);

}  // namespace maps::experiments
