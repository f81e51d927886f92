#pragma once

// Shared helpers of the baseline policy tests: a tiny two-task dataset, batch surgery and error capture.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "maps/data/batch.h"
#include "maps/policies/policy.h"
#include "nn/optim/adam.h"
#include "tests/common/error_of.h"
#include "tests/common/max_abs_diff.h"

namespace baselinetest {

namespace ag = maps::ag;
namespace core = maps::core;
using ag::Dtype;
using ag::Tensor;
using ::testing::HasSubstr;

using ::error_of;

using ::max_abs_diff;

// A different smooth map R^3 -> R^2 per task (tasks 0..3), values of order 1.
inline std::vector<double> target(std::int64_t task, const double* s) {
  switch (task) {
    case 0:
      return {std::sin(2.0 * s[0]) + 0.5 * s[1], std::cos(s[2]) * s[0]};
    case 1:
      return {0.3 - s[0] * s[1], std::sin(s[1] + s[2])};
    case 2:
      return {std::tanh(s[2] - s[0]), 0.5 * s[1] * s[1] - 0.2};
    default:
      return {std::cos(s[0] + s[1]), -s[2]};
  }
}

// A balanced batch (S = 3, A = 2): per_task states per task, uniform in [-1, 1], actions from target().
inline core::Batch make_batch(std::int64_t tasks, std::int64_t per_task, std::uint64_t seed,
                              Dtype dtype = Dtype::Float32) {
  ag::Generator gen(seed);
  const std::int64_t n = tasks * per_task;
  core::Batch b;
  b.observations = ag::rand({n, 3}, gen, Dtype::Float64, -1.0, 1.0);
  std::vector<double> actions;
  for (std::int64_t j = 0; j < n; ++j) {
    b.tasks.push_back(j / per_task);
    const std::vector<double> a = target(j / per_task, b.observations.data<double>() + 3 * j);
    actions.insert(actions.end(), a.begin(), a.end());
  }
  b.observations = b.observations.to(dtype);
  b.previous_observations = b.observations;
  b.actions = ag::from_vector(actions, {n, 2}, dtype);
  b.per_task = per_task;
  return b;
}

// The batch's rows in the given order (per_task = 0: no longer balanced).
inline core::Batch rows_of(const core::Batch& b, const std::vector<std::int64_t>& rows) {
  core::Batch out;
  out.observations = ag::index_select(b.observations, rows);
  out.previous_observations = ag::index_select(b.previous_observations, rows);
  out.actions = ag::index_select(b.actions, rows);
  for (std::int64_t r : rows) out.tasks.push_back(b.tasks[static_cast<std::size_t>(r)]);
  return out;
}

// A fixed shuffle of 0..n-1 that mixes tasks.
inline std::vector<std::int64_t> shuffled_rows(std::int64_t n, std::uint64_t seed) {
  std::vector<std::int64_t> rows(static_cast<std::size_t>(n));
  for (std::int64_t i = 0; i < n; ++i) rows[static_cast<std::size_t>(i)] = i;
  ag::Generator gen(seed);
  std::shuffle(rows.begin(), rows.end(), gen.engine());
  return rows;
}

// Adam on policy.loss(batch).total for `steps` steps; returns the loss before each step and the final one.
inline std::vector<double> train(core::Policy& policy, const core::Batch& batch, int steps, double lr) {
  maps::optim::Adam adam(policy.parameters(), {.lr = lr});
  std::vector<double> losses;
  for (int i = 0; i < steps; ++i) {
    adam.zero_grad();
    const Tensor loss = policy.loss(batch).total;
    losses.push_back(loss.item());
    loss.backward();
    adam.step();
  }
  losses.push_back(policy.loss(batch).total.item());
  return losses;
}

}  // namespace baselinetest
