#include "maps/policies/baseline_util.h"

#include <stdexcept>

namespace maps::core::detail {

void check_construction(const std::string& type_name, const PolicyShape& shape,
                        const std::vector<std::int64_t>& hidden_sizes, bool need_hidden) {
  if (shape.observation_size <= 0 || shape.action_size <= 0 || shape.num_tasks <= 0)
    throw std::invalid_argument(type_name + ": observation_size, action_size and num_tasks must be positive, got " +
                                std::to_string(shape.observation_size) + ", " + std::to_string(shape.action_size) +
                                ", " + std::to_string(shape.num_tasks));
  if (need_hidden && hidden_sizes.empty())
    throw std::invalid_argument(type_name + ": expected at least one hidden layer size");
  for (std::int64_t h : hidden_sizes)
    if (h <= 0)
      throw std::invalid_argument(type_name + ": hidden layer sizes must be positive, got " +
                                  ag::to_string(hidden_sizes));
}

std::vector<std::int64_t> layer_sizes(std::int64_t in, const std::vector<std::int64_t>& hidden, std::int64_t out) {
  std::vector<std::int64_t> sizes{in};
  sizes.insert(sizes.end(), hidden.begin(), hidden.end());
  sizes.push_back(out);
  return sizes;
}

void check_observations(const std::string& where, const PolicyShape& shape, const ag::Tensor& observations,
                        const std::vector<std::int64_t>& tasks) {
  if (!observations.defined() || observations.dim() != 2 || observations.size(1) != shape.observation_size)
    throw std::invalid_argument(where + ": expected observations [n, " + std::to_string(shape.observation_size) +
                                "], got " + ag::shape_text(observations));
  if (static_cast<std::int64_t>(tasks.size()) != observations.size(0))
    throw std::invalid_argument(where + ": expected one task index per observation row (" +
                                std::to_string(observations.size(0)) + "), got " + std::to_string(tasks.size()));
  for (std::size_t j = 0; j < tasks.size(); ++j)
    if (tasks[j] < 0 || tasks[j] >= shape.num_tasks)
      throw std::out_of_range(where + ": task " + std::to_string(tasks[j]) + " at row " + std::to_string(j) +
                              " is outside [0, " + std::to_string(shape.num_tasks) + ")");
}

void check_batch(const std::string& where, const PolicyShape& shape, const Batch& batch) {
  check_observations(where, shape, batch.observations, batch.tasks);
  const std::int64_t n = batch.size();
  if (!batch.actions.defined() || batch.actions.dim() != 2 || batch.actions.size(0) != n ||
      batch.actions.size(1) != shape.action_size)
    throw std::invalid_argument(where + ": expected actions [" + std::to_string(n) + ", " +
                                std::to_string(shape.action_size) + "], got " + ag::shape_text(batch.actions));
  if (batch.per_task < 0)
    throw std::invalid_argument(where + ": per_task must be >= 0, got " + std::to_string(batch.per_task));
  if (batch.per_task == 0) return;
  if (n != shape.num_tasks * batch.per_task)
    throw std::invalid_argument(where + ": a balanced batch of per_task " + std::to_string(batch.per_task) + " for " +
                                std::to_string(shape.num_tasks) + " tasks must hold " +
                                std::to_string(shape.num_tasks * batch.per_task) + " rows, got " + std::to_string(n));
  for (std::int64_t j = 0; j < n; ++j)
    if (batch.tasks[static_cast<std::size_t>(j)] != j / batch.per_task)
      throw std::invalid_argument(where + ": a balanced batch must be task-major (row " + std::to_string(j) +
                                  " should be task " + std::to_string(j / batch.per_task) + ", got " +
                                  std::to_string(batch.tasks[static_cast<std::size_t>(j)]) + ")");
}

void check_balanced_batch(const std::string& where, const PolicyShape& shape, const Batch& batch) {
  if (batch.per_task <= 0)
    throw std::invalid_argument(where +
                                ": expected a balanced batch (per_task > 0, rows grouped by task), got per_task " +
                                std::to_string(batch.per_task));
  check_batch(where, shape, batch);
}

ag::Tensor with_task_one_hot(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks,
                             std::int64_t num_tasks) {
  return ag::concat({observations, ag::one_hot(tasks, num_tasks, observations.dtype())}, 1);
}

LossTerms bc_terms(const ag::Tensor& bc) { return LossTerms{bc, {{"bc", bc}}}; }

ag::Tensor task_weight_shares(const ag::Tensor& weights, const std::vector<std::int64_t>& tasks) {
  const ag::Tensor magnitude = ag::abs(ag::index_select(weights, tasks));
  return ag::div(magnitude, ag::sum(magnitude, {1}, true));
}

}  // namespace maps::core::detail
