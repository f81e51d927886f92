#include "experiments/process/cpu_model.h"

#include <fstream>

namespace maps::experiments {

std::string cpu_model_from(std::istream& cpuinfo) {
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const auto begin = line.find_first_not_of(" \t\r", colon + 1);
    if (begin == std::string::npos) return "";
    const auto end = line.find_last_not_of(" \t\r");
    return line.substr(begin, end - begin + 1);
  }
  return "";
}

std::string cpu_model_at(const std::string& path) {
  std::ifstream cpuinfo(path);
  const std::string found = cpuinfo ? cpu_model_from(cpuinfo) : std::string();
  return found.empty() ? std::string("unknown") : found;
}

std::string cpu_model() {
  static const std::string model = cpu_model_at("/proc/cpuinfo");
  return model;
}

}  // namespace maps::experiments
