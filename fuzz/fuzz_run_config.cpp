// Run configs (maps train --config): any JSON either parses into a config that survives its own round trip and
// builds a policy, or is refused with an exception; never a crash, a hang or a silent change.

#include <cstdint>
#include <cstdlib>
#include <exception>
#include <nlohmann/json.hpp>

#include "maps/training/run_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const nlohmann::json json = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return 0;
  try {
    const maps::core::RunConfig config = maps::core::parse_run_config(json);
    const nlohmann::json resolved = maps::core::to_json(config);
    if (maps::core::to_json(maps::core::parse_run_config(resolved)) != resolved) std::abort();  // not a fixed point
    maps::core::make_policy(config, {3, 2, 2});
  } catch (const std::exception&) {
  }
  return 0;
}
