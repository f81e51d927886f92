#include "maps/policies/mt_mh_bc.h"

#include "maps/policies/policy_registry.h"
#include "nn/mlp.h"
#include "nn/parallel_linear.h"

namespace maps::core {

MTMHBC::MTMHBC(PolicyShape shape, ag::Generator& gen, const std::vector<std::int64_t>& hidden_sizes,
               nn::Activation activation)
    : Policy("MTMHBC", shape) {
  detail::check_construction("MTMHBC", shape, hidden_sizes, /*need_hidden=*/true);
  std::vector<std::int64_t> trunk_sizes{shape.observation_size};
  trunk_sizes.insert(trunk_sizes.end(), hidden_sizes.begin(), hidden_sizes.end());
  trunk_ = register_module("trunk", std::make_shared<nn::MLP>(trunk_sizes, activation, gen, /*activate_last=*/true));
  heads_ = register_module(
      "heads", std::make_shared<nn::ParallelLinear>(shape.num_tasks, hidden_sizes.back(), shape.action_size, gen));
}

ag::Tensor MTMHBC::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("MTMHBC::act", shape(), observations, tasks);
  const ag::Tensor features = child_at<nn::MLP>(trunk_).forward(observations);
  const ag::Tensor all = child_at<nn::ParallelLinear>(heads_).forward(features);  // [K, n, A]
  return ag::index_select(ag::reshape(all, {-1, shape().action_size}), own_task_rows(tasks));
}

ag::Tensor MTMHBC::predict(const Batch& batch) {
  detail::check_batch("MTMHBC::predict", shape(), batch);
  if (batch.per_task == 0) return act(batch.observations, batch.tasks);
  const ag::Tensor features = child_at<nn::MLP>(trunk_).forward(batch.observations);
  const ag::Tensor grouped = ag::reshape(features, {shape().num_tasks, batch.per_task, features.size(1)});
  return ag::reshape(child_at<nn::ParallelLinear>(heads_).forward(grouped), {batch.size(), shape().action_size});
}

LossTerms MTMHBC::loss(const Batch& batch) {
  detail::check_batch("MTMHBC::loss", shape(), batch);
  return detail::bc_terms(bc_loss(predict(batch), batch));
}

PolicyMethod mt_mh_bc_method() {
  PolicyMethod method;
  method.name = "mt_mh_bc";
  method.summary = "MT-MH-BC: a shared trunk MLP on the state and one linear head per task (baselines.hidden)";
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    std::vector<std::int64_t> trunk{shape.observation_size};
    trunk.insert(trunk.end(), o.baseline_hidden.begin(), o.baseline_hidden.end());
    return mlp_parameter_count(trunk) +
           static_cast<double>(shape.num_tasks) * mlp_parameter_count({o.baseline_hidden.back(), shape.action_size});
  };
  method.size_keys = "baselines.hidden";
  method.uses_baselines_hidden = true;
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<MTMHBC>(shape, gen, o.baseline_hidden);
  };
  return method;
}

}  // namespace maps::core
