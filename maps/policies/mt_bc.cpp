#include "maps/policies/mt_bc.h"

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
  const ag::Tensor onehot = ag::one_hot(tasks, shape().num_tasks, observations.dtype());
  return child_at<nn::MLP>(mlp_).forward(ag::concat({observations, onehot}, 1));
}

ag::Tensor MTBC::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("MTBC::act", shape(), observations, tasks);
  return forward(observations, tasks);
}

LossTerms MTBC::loss(const Batch& batch) {
  detail::check_batch("MTBC::loss", shape(), batch);
  return detail::bc_terms(bc_loss(forward(batch.observations, batch.tasks), batch));
}

}  // namespace maps::core
