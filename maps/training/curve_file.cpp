#include "maps/training/curve_file.h"

#include <algorithm>
#include <charconv>
#include <ctime>
#include <fstream>
#include <stdexcept>

#include "io/atomic_file.h"

namespace maps::core {

void truncate_curve(const std::string& path, std::int64_t step) {
  std::ifstream in(path);
  if (!in) return;
  std::string header;
  if (!std::getline(in, header)) return;
  const auto columns = std::count(header.begin(), header.end(), ',');
  std::string kept = header + "\n";
  std::string line;
  for (int number = 2; std::getline(in, line); ++number) {
    // A row cut short by a kill mid-append has fewer columns; the resumed run writes it again.
    if (std::count(line.begin(), line.end(), ',') != columns) continue;
    const std::string first = line.substr(0, line.find(','));
    std::int64_t row_step = 0;
    const auto [end, error] = std::from_chars(first.data(), first.data() + first.size(), row_step);
    if (error != std::errc() || end != first.data() + first.size() || row_step < 0)
      throw std::runtime_error(path + " line " + std::to_string(number) + ": the step '" + first.substr(0, 40) +
                               "' is not a step number (a damaged curve: move it away, and the resumed run starts a "
                               "new one from its checkpoint's step)");
    if (row_step <= step) kept += line + "\n";
  }
  in.close();
  io::write_file_atomically(path, kept);
}

bool curve_has_cpu_column(const std::string& path) {
  std::ifstream in(path);
  std::string header;
  if (!std::getline(in, header) || header.empty()) return true;
  return header.size() >= 12 && header.compare(header.size() - 12, 12, ",cpu_seconds") == 0;
}

double process_cpu_seconds() {
  timespec now{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

}  // namespace maps::core
