#include "maps/policies/mt_bc.h"

#include "maps/policies/policy_registry.h"
#include "nn/mlp.h"

namespace maps::core {

MTBC::MTBC(PolicyShape shape, ag::Generator& gen, const std::vector<std::int64_t>& hidden_sizes,
           nn::Activation activation)
    : Policy("MTBC", shape) {
  detail::check_construction("MTBC", shape, hidden_sizes, /*need_hidden=*/false);
  mlp_ = register_module("mlp", std::make_shared<nn::MLP>(detail::layer_sizes(shape.observation_size + shape.num_tasks,
                                                                              hidden_sizes, shape.action_size),
                                                          activation, gen));
}

ag::Tensor MTBC::forward(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  return child_at<nn::MLP>(mlp_).forward(detail::with_task_one_hot(observations, tasks, shape().num_tasks));
}

ag::Tensor MTBC::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("MTBC::act", shape(), observations, tasks);
  return forward(observations, tasks);
}

LossTerms MTBC::loss(const Batch& batch) {
  detail::check_batch("MTBC::loss", shape(), batch);
  return detail::bc_terms(bc_loss(forward(batch.observations, batch.tasks), batch));
}

PolicyMethod mt_bc_method() {
  PolicyMethod method;
  method.name = "mt_bc";
  method.summary = "MT-BC: one MLP on [state, one-hot task] for every task (baselines.hidden)";
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return mlp_parameter_count(
        detail::layer_sizes(shape.observation_size + shape.num_tasks, o.baseline_hidden, shape.action_size));
  };
  method.size_keys = "baselines.hidden";
  method.uses_baselines_hidden = true;
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<MTBC>(shape, gen, o.baseline_hidden);
  };
  return method;
}

}  // namespace maps::core
