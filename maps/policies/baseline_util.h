#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "maps/data/batch.h"
#include "maps/policies/policy.h"

// Input checks and sizes shared by the policies (the baselines SingleBC, MTBC, MTMHBC, MAML; MAPS's checks). Every
// error names `where`
// ("SingleBC::act") and what was expected, so a wiring mistake in the trainer points at the policy it reached.
namespace maps::core::detail {

// The paper's policy MLP: three hidden layers of 128 (PAPER.md, "Baselines").
inline const std::vector<std::int64_t>& default_hidden_sizes() {
  static const std::vector<std::int64_t> sizes{128, 128, 128};
  return sizes;
}

// Throws unless S, A and K are positive and every hidden size is positive (and, when required, there is one).
void check_construction(const std::string& type_name, const PolicyShape& shape,
                        const std::vector<std::int64_t>& hidden_sizes, bool need_hidden);

// {in, hidden..., out}.
std::vector<std::int64_t> layer_sizes(std::int64_t in, const std::vector<std::int64_t>& hidden, std::int64_t out);

// observations [n, S] with one task index in [0, K) per row.
void check_observations(const std::string& where, const PolicyShape& shape, const ag::Tensor& observations,
                        const std::vector<std::int64_t>& tasks);

// check_observations, actions [n, A], and, when per_task > 0, the balanced layout (n = K * per_task, task-major).
void check_batch(const std::string& where, const PolicyShape& shape, const Batch& batch);

// check_batch and per_task > 0.
void check_balanced_batch(const std::string& where, const PolicyShape& shape, const Batch& batch);

// [observations, one_hot(tasks)] [n, S + K]: the input of the methods told their task beside the state.
ag::Tensor with_task_one_hot(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks,
                             std::int64_t num_tasks);

// The BC loss as the only term.
LossTerms bc_terms(const ag::Tensor& bc);

// Rows |w_{tasks[j]}| / sum |w_{tasks[j]}| of per-task weights [K, m]: each module's share in each row's mixture, for
// the methods whose modules are weighted by the task alone (MOORE, PaCo): Policy::routing.
ag::Tensor task_weight_shares(const ag::Tensor& weights, const std::vector<std::int64_t>& tasks);

}  // namespace maps::core::detail
