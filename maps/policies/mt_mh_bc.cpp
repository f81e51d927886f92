#include "maps/policies/mt_mh_bc.h"

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

}  // namespace maps::core
