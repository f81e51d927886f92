#include "maps/policies/single_bc.h"

#include <algorithm>

#include "maps/policies/policy_registry.h"
#include "nn/module_list.h"
#include "nn/parallel_linear.h"

namespace maps::core {

SingleBC::SingleBC(PolicyShape shape, ag::Generator& gen, const std::vector<std::int64_t>& hidden_sizes,
                   nn::Activation activation)
    : Policy("SingleBC", shape), activation_(activation) {
  detail::check_construction("SingleBC", shape, hidden_sizes, /*need_hidden=*/false);
  const std::vector<std::int64_t> sizes = detail::layer_sizes(shape.observation_size, hidden_sizes, shape.action_size);
  auto layers = std::make_shared<nn::ModuleList>();
  for (std::size_t i = 0; i + 1 < sizes.size(); ++i)
    layers->push_back(std::make_shared<nn::ParallelLinear>(shape.num_tasks, sizes[i], sizes[i + 1], gen));
  layers_ = register_module("layers", layers);
}

ag::Tensor SingleBC::run(const ag::Tensor& x) {
  const auto& layers = child_at<nn::ModuleList>(layers_);
  ag::Tensor y = x;
  for (std::size_t i = 0; i < layers.size(); ++i) {
    y = layers.at<nn::ParallelLinear>(i).forward(y);
    if (i + 1 < layers.size()) y = nn::apply_activation(activation_, y);
  }
  return y;
}

ag::Tensor SingleBC::forward_all(const ag::Tensor& observations) {
  const std::vector<std::int64_t> no_tasks(static_cast<std::size_t>(observations.defined() ? observations.size(0) : 0),
                                           0);
  detail::check_observations("SingleBC::forward_all", shape(), observations, no_tasks);
  return run(observations);
}

ag::Tensor SingleBC::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("SingleBC::act", shape(), observations, tasks);
  if (tasks.empty()) return ag::reshape(run(observations), {0, shape().action_size});  // no row to gather from
  const std::int64_t K = shape().num_tasks;
  std::vector<std::vector<std::int64_t>> groups(static_cast<std::size_t>(K));
  for (std::size_t j = 0; j < tasks.size(); ++j)
    groups[static_cast<std::size_t>(tasks[j])].push_back(static_cast<std::int64_t>(j));
  std::int64_t m = 1;
  for (const auto& rows : groups) m = std::max<std::int64_t>(m, static_cast<std::int64_t>(rows.size()));
  std::vector<std::int64_t> gather(static_cast<std::size_t>(K * m), 0), place(tasks.size());
  for (std::int64_t k = 0; k < K; ++k) {
    const auto& rows = groups[static_cast<std::size_t>(k)];
    for (std::int64_t i = 0; i < m; ++i) {
      const auto slot = static_cast<std::size_t>(k * m + i);
      if (i < static_cast<std::int64_t>(rows.size())) {
        gather[slot] = rows[static_cast<std::size_t>(i)];
        place[static_cast<std::size_t>(rows[static_cast<std::size_t>(i)])] = k * m + i;
      } else if (!rows.empty()) {
        gather[slot] = rows.front();
      }
    }
  }
  const ag::Tensor grouped =
      ag::reshape(ag::index_select(observations, gather), {K, m, shape().observation_size});  // [K, m, S]
  return ag::index_select(ag::reshape(run(grouped), {K * m, shape().action_size}), place);
}

PolicyForward SingleBC::forward_terms(const Batch& batch) { return {predict(batch), {}}; }

ag::Tensor SingleBC::predict(const Batch& batch) {
  detail::check_batch("SingleBC::predict", shape(), batch);
  if (batch.per_task == 0) return act(batch.observations, batch.tasks);
  const ag::Tensor x = ag::reshape(batch.observations, {shape().num_tasks, batch.per_task, shape().observation_size});
  return ag::reshape(run(x), {batch.size(), shape().action_size});
}

LossTerms SingleBC::loss(const Batch& batch) {
  detail::check_batch("SingleBC::loss", shape(), batch);
  return detail::bc_terms(bc_loss(predict(batch), batch));
}

PolicyMethod single_bc_method() {
  PolicyMethod method;
  method.name = "single_bc";
  method.summary = "Single BC: one MLP per task, each trained on its own task's demonstrations (baselines.hidden)";
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return static_cast<double>(shape.num_tasks) *
           mlp_parameter_count(detail::layer_sizes(shape.observation_size, o.baseline_hidden, shape.action_size));
  };
  method.size_keys = "baselines.hidden";
  method.uses_baselines_hidden = true;
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<SingleBC>(shape, gen, o.baseline_hidden);
  };
  return method;
}

}  // namespace maps::core
