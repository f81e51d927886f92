#include "maps/evaluation/step_actions.h"

#include <stdexcept>

namespace maps::core {

ag::RowMatrixD step_actions(Policy& policy, const ag::Tensor& x, const ag::Tensor& before, std::int64_t task_id,
                            const std::vector<chunking::ChunkExecutor*>& executors, const std::string& where) {
  const chunking::ActionChunking& chunking = policy.chunking();
  const std::int64_t n = x.size(0);
  const std::int64_t action_size = policy.step_action_size();
  const std::int64_t predicted_size = chunking.chunked() ? chunking.horizon * action_size : action_size;
  auto checked = [&](const ag::Tensor& a, std::int64_t rows) {
    if (!a.defined() || a.dim() != 2 || a.size(0) != rows || a.size(1) != predicted_size)
      throw std::runtime_error(where + ": the policy returned actions of shape " + ag::shape_text(a) + ", expected [" +
                               std::to_string(rows) + ", " + std::to_string(predicted_size) + "] (one row per " +
                               (chunking.chunked() ? "episode asking for a chunk" : "running episode") + ")");
    return ag::to_eigen_double(a);
  };
  if (!chunking.chunked()) {
    if (!executors.empty()) throw std::invalid_argument(where + ": executors given for a policy acting per step");
    const std::vector<std::int64_t> ids(static_cast<std::size_t>(n), task_id);
    return checked(chunking.previous_observation ? policy.act_with_history(x, before, ids) : policy.act(x, ids), n);
  }
  if (static_cast<std::int64_t>(executors.size()) != n)
    throw std::invalid_argument(where + ": " + std::to_string(executors.size()) + " executors for " +
                                std::to_string(n) + " running episodes");
  // Only the episodes whose executor asks for a chunk query the policy (all of them when ensembling).
  std::vector<std::int64_t> asking;
  for (std::int64_t j = 0; j < n; ++j)
    if (executors[static_cast<std::size_t>(j)]->needs_chunk()) asking.push_back(j);
  if (!asking.empty()) {
    const ag::RowMatrixD chunks =
        checked(policy.act_with_history(ag::index_select(x, asking), ag::index_select(before, asking),
                                        std::vector<std::int64_t>(asking.size(), task_id)),
                static_cast<std::int64_t>(asking.size()));
    for (std::size_t i = 0; i < asking.size(); ++i)
      executors[static_cast<std::size_t>(asking[i])]->add(chunks.row(static_cast<Eigen::Index>(i)).transpose());
  }
  ag::RowMatrixD actions(n, action_size);
  for (std::int64_t j = 0; j < n; ++j)
    actions.row(static_cast<Eigen::Index>(j)) = executors[static_cast<std::size_t>(j)]->action().transpose();
  return actions;
}

}  // namespace maps::core
