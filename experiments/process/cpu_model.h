#pragma once

#include <istream>
#include <string>

// Which CPU a figure was measured on: speed and CPU-time figures mean little without it, and a host name names a
// VM, not its CPU (machines of this project have been AMD Zen 3, Zen 5 and Intel Xeon, up to 1.7x apart).
namespace maps::experiments {

// This machine's CPU model name as /proc/cpuinfo gives it ("AMD EPYC", "Intel(R) Xeon(R) Processor"), "unknown"
// where it cannot be read. Read once.
std::string cpu_model();
// The same from the cpuinfo text at `path`: "unknown" when the file cannot be read or names no model.
std::string cpu_model_at(const std::string& path);
// The first "model name" line's value in a /proc/cpuinfo text (spaces and a CR trimmed), "" without one.
std::string cpu_model_from(std::istream& cpuinfo);

}  // namespace maps::experiments
