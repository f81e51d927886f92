#include "maps/training/curve_cost.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <numeric>
#include <sstream>
#include <vector>

namespace maps::core {

namespace {

// A curve saved through a tool that ends lines with CRLF reads the same.
std::vector<std::string> split_row(std::string line) {
  if (!line.empty() && line.back() == '\r') line.pop_back();
  std::vector<std::string> fields;
  std::istringstream in(line);
  for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
  return fields;
}

// The field's number when the whole field is one, else NaN.
double number_of(const std::string& field) {
  std::size_t used = 0;
  try {
    const double value = std::stod(field, &used);
    return used == field.size() ? value : NAN;
  } catch (const std::exception&) {
    return NAN;
  }
}

using Window = std::function<double(double at, double previous, const std::vector<std::string>& row)>;

// The seconds each window of a curve records up to `target` in its column `step_name`: the window that
// choose(column_of) makes from the header (std::nullopt: the curve cannot say) of each row, each row's step above the
// one before. std::nullopt when the file is missing or unreadable, a row is cut, a window is not a positive finite
// number, or the rows do not end at `target`.
std::optional<std::vector<double>> windows_of(
    const std::string& curve_path, const std::string& step_name, double target,
    const std::function<std::optional<Window>(const std::function<std::ptrdiff_t(const std::string&)>& column_of)>&
        choose) {
  std::ifstream in(curve_path);
  std::string line;
  if (!in || !std::getline(in, line)) return std::nullopt;
  const std::vector<std::string> header = split_row(line);
  const auto column_of = [&header](const std::string& name) {
    for (std::size_t i = 0; i < header.size(); ++i)
      if (header[i] == name) return static_cast<std::ptrdiff_t>(i);
    return std::ptrdiff_t{-1};
  };
  const std::ptrdiff_t step_column = column_of(step_name);
  const std::optional<Window> window = choose(column_of);
  if (step_column < 0 || !window) return std::nullopt;
  std::vector<double> seconds;
  double previous = 0.0;
  while (std::getline(in, line)) {
    const std::vector<std::string> row = split_row(line);
    if (row.size() != header.size()) return std::nullopt;
    const double at = number_of(row[static_cast<std::size_t>(step_column)]);
    if (!std::isfinite(at)) return std::nullopt;
    if (at > target) break;
    const double value = (*window)(at, previous, row);
    if (!(value > 0.0) || !std::isfinite(value)) return std::nullopt;
    seconds.push_back(value);
    previous = at;
  }
  if (previous != target) return std::nullopt;
  return seconds;
}

// The number in a row's column (the column a header search found).
double field(const std::vector<std::string>& row, std::ptrdiff_t column) {
  return number_of(row[static_cast<std::size_t>(column)]);
}

}  // namespace

std::optional<CurveCost> curve_training_cost(const std::string& curve_path, std::int64_t steps) {
  CurveCost cost;
  const auto seconds = windows_of(curve_path, "step", static_cast<double>(steps), [&cost](const auto& column_of) {
    const std::ptrdiff_t speed = column_of("steps_per_second"), cpu = column_of("cpu_seconds");
    cost.cpu = cpu >= 0;
    if (cost.cpu) return std::optional<Window>([cpu](double, double, const auto& row) { return field(row, cpu); });
    if (speed < 0) return std::optional<Window>();
    return std::optional<Window>(
        [speed](double at, double previous, const auto& row) { return (at - previous) / field(row, speed); });
  });
  if (!seconds) return std::nullopt;
  cost.seconds = std::accumulate(seconds->begin(), seconds->end(), 0.0);
  return cost;
}

std::optional<CurveCost> gail_curve_training_cost(const std::string& curve_path, std::int64_t env_steps_per_task,
                                                  std::int64_t tasks) {
  if (tasks <= 0) return std::nullopt;
  bool cpu = false;
  const auto seconds = windows_of(
      curve_path, "env_steps_per_task", static_cast<double>(env_steps_per_task), [tasks, &cpu](const auto& column_of) {
        const std::ptrdiff_t speed = column_of("env_steps_per_second"), cpu_column = column_of("cpu_seconds");
        cpu = cpu_column >= 0;
        if (cpu)
          return std::optional<Window>(
              [cpu_column](double, double, const auto& row) { return field(row, cpu_column); });
        if (speed < 0) return std::optional<Window>();
        return std::optional<Window>([speed, tasks](double at, double previous, const auto& row) {
          return (at - previous) * static_cast<double>(tasks) / field(row, speed);
        });
      });
  if (!seconds) return std::nullopt;
  // CPU time does not grow while a process is stopped: only the speeds' wall times need the rule.
  return CurveCost{cpu ? std::accumulate(seconds->begin(), seconds->end(), 0.0) : sum_without_stops(*seconds), cpu};
}

double sum_without_stops(const std::vector<double>& seconds) {
  if (seconds.empty()) return 0.0;
  std::vector<double> sorted = seconds;
  const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), middle, sorted.end());
  double median = *middle;
  if (sorted.size() % 2 == 0) median = (median + *std::max_element(sorted.begin(), middle)) / 2.0;
  double sum = 0.0;
  for (const double s : seconds) sum += s > kStoppedFactor * median ? median : s;
  return sum;
}

}  // namespace maps::core
