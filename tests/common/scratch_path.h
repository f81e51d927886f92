#pragma once

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

// A path in the temporary folder for tests written as plain TESTs: named by the process too (ctest runs test
// programs in parallel), absent when returned, and removed with whatever was written there when the program ends.
inline std::filesystem::path scratch_path(const std::string& name) {
  struct RemovedAtExit {
    std::vector<std::filesystem::path> paths;
    ~RemovedAtExit() {
      std::error_code ignored;
      for (const auto& path : paths) std::filesystem::remove_all(path, ignored);
    }
  };
  static RemovedAtExit made;
  const auto path = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(path);
  made.paths.push_back(path);
  return path;
}
