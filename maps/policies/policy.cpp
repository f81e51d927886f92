#include "maps/policies/policy.h"

namespace maps::core {

std::vector<std::int64_t> own_task_rows(const std::vector<std::int64_t>& tasks) {
  const auto n = static_cast<std::int64_t>(tasks.size());
  std::vector<std::int64_t> rows(tasks.size());
  for (std::int64_t j = 0; j < n; ++j) rows[static_cast<std::size_t>(j)] = tasks[static_cast<std::size_t>(j)] * n + j;
  return rows;
}

}  // namespace maps::core
