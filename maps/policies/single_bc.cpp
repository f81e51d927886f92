#include "maps/policies/single_bc.h"

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
  const ag::Tensor all = run(observations);  // [K, n, A]
  return ag::index_select(ag::reshape(all, {-1, shape().action_size}), own_task_rows(tasks));
}

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
