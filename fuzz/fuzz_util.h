#pragma once

// Helpers of the fuzz targets: a scratch file per process for readers that take a path.

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace maps::fuzz {

// A file in the temporary folder holding `data` (the same path for every input of this process).
inline std::string scratch_file(const std::uint8_t* data, std::size_t size, const std::string& suffix) {
  static const std::string path =
      (std::filesystem::temp_directory_path() / ("maps-fuzz-" + std::to_string(::getpid()) + suffix)).string();
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

}  // namespace maps::fuzz
