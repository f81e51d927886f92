// Suite configs (maps suite plan/run): any JSON either expands into cells whose run configs all parse, or is
// refused with an exception.

#include <cstdint>
#include <cstdlib>
#include <exception>
#include <nlohmann/json.hpp>

#include "experiments/suite/config.h"
#include "maps/training/run_config.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const nlohmann::json json = nlohmann::json::parse(data, data + size, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return 0;
  try {
    const maps::experiments::Suite suite = maps::experiments::parse_suite(json, "fuzz.json");
    for (const auto& cell : suite.cells) maps::core::parse_run_config(cell.request);  // parse_suite checked them
  } catch (const std::exception&) {
  }
  return 0;
}
