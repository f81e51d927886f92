#include "envs/demo_file.h"

// The DemoFile types' own functions. The rest of envs/demo_file.h is in envs/demo_file/: writer.cpp, reader.cpp
// (format 2 and format 1), validation.cpp, isolated_read.cpp (read_demo_file's child process), split.cpp.
namespace maps::envs {

std::int64_t DemoFile::total_samples() const {
  std::int64_t total = 0;
  for (const auto& d : demos) total += d.num_samples();
  return total;
}

std::string demo_name(int i) { return "demo_" + std::to_string(i); }

const char* episode_end_name(EpisodeEnd end) {
  switch (end) {
    case EpisodeEnd::kTerminated:
      return "terminated";
    case EpisodeEnd::kTruncated:
      return "truncated";
    case EpisodeEnd::kUnknown:
      break;
  }
  return "unknown";
}

}  // namespace maps::envs
