#include "maps/training/curve_cost.h"

#include <cmath>
#include <fstream>
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

}  // namespace

std::optional<CurveCost> curve_training_cost(const std::string& curve_path, std::int64_t steps) {
  std::ifstream in(curve_path);
  std::string line;
  if (!in || !std::getline(in, line)) return std::nullopt;
  const std::vector<std::string> header = split_row(line);
  std::ptrdiff_t step_column = -1, speed_column = -1, cpu_column = -1;
  for (std::size_t i = 0; i < header.size(); ++i) {
    const auto index = static_cast<std::ptrdiff_t>(i);
    if (header[i] == "step") step_column = index;
    if (header[i] == "steps_per_second") speed_column = index;
    if (header[i] == "cpu_seconds") cpu_column = index;
  }
  if (step_column < 0 || (speed_column < 0 && cpu_column < 0)) return std::nullopt;
  CurveCost cost;
  cost.cpu = cpu_column >= 0;
  double previous = 0.0;
  while (std::getline(in, line)) {
    const std::vector<std::string> row = split_row(line);
    if (row.size() != header.size()) return std::nullopt;
    const double at = number_of(row[static_cast<std::size_t>(step_column)]);
    if (!std::isfinite(at)) return std::nullopt;
    if (at > static_cast<double>(steps)) break;
    const double window = cost.cpu ? number_of(row[static_cast<std::size_t>(cpu_column)])
                                   : (at - previous) / number_of(row[static_cast<std::size_t>(speed_column)]);
    if (!(window > 0.0) || !std::isfinite(window)) return std::nullopt;
    cost.seconds += window;
    previous = at;
  }
  if (previous != static_cast<double>(steps)) return std::nullopt;
  return cost;
}

std::optional<CurveCost> gail_curve_training_cost(const std::string& curve_path, std::int64_t env_steps_per_task,
                                                  std::int64_t tasks) {
  if (tasks <= 0) return std::nullopt;
  std::ifstream in(curve_path);
  std::string line;
  if (!in || !std::getline(in, line)) return std::nullopt;
  const std::vector<std::string> header = split_row(line);
  std::ptrdiff_t steps_column = -1, speed_column = -1;
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (header[i] == "env_steps_per_task") steps_column = static_cast<std::ptrdiff_t>(i);
    if (header[i] == "env_steps_per_second") speed_column = static_cast<std::ptrdiff_t>(i);
  }
  if (steps_column < 0 || speed_column < 0) return std::nullopt;
  CurveCost cost;
  double previous = 0.0;
  while (std::getline(in, line)) {
    const std::vector<std::string> row = split_row(line);
    if (row.size() != header.size()) return std::nullopt;
    const double at = number_of(row[static_cast<std::size_t>(steps_column)]);
    if (!std::isfinite(at) || !(at > previous)) return std::nullopt;
    if (at > static_cast<double>(env_steps_per_task)) break;
    const double seconds =
        (at - previous) * static_cast<double>(tasks) / number_of(row[static_cast<std::size_t>(speed_column)]);
    if (!(seconds > 0.0) || !std::isfinite(seconds)) return std::nullopt;
    cost.seconds += seconds;
    previous = at;
  }
  if (previous != static_cast<double>(env_steps_per_task)) return std::nullopt;
  return cost;
}

}  // namespace maps::core
