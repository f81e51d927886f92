#pragma once

#include <chrono>
#include <string>

// Facts of this process's machine and clock that results and logs record.
namespace maps::experiments {

std::string host_name();  // "unknown" when it cannot be read
std::string utc_now();    // "2026-12-02T08:25:22Z"
double seconds_since(std::chrono::steady_clock::time_point start);

}  // namespace maps::experiments
