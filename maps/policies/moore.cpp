#include "maps/policies/moore.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy_registry.h"
#include "nn/init.h"
#include "nn/module_list.h"
#include "nn/parallel_linear.h"

namespace maps::core {

MOORE::MOORE(PolicyShape shape, const MOOREConfig& config, ag::Generator& gen)
    : Policy("MOORE", shape), config_(config) {
  detail::check_construction("MOORE", shape, {config.width}, /*need_hidden=*/true);
  if (config.experts < 1 || config.layers < 1)
    throw std::invalid_argument("MOORE: experts and layers must be >= 1, got " + std::to_string(config.experts) +
                                " and " + std::to_string(config.layers));
  if (config.orthogonal && config.experts > config.width)
    throw std::invalid_argument("MOORE: " + std::to_string(config.experts) +
                                " experts cannot be orthonormal in width " + std::to_string(config.width) +
                                " (moore.experts <= moore.width)");
  auto layers = std::make_shared<nn::ModuleList>();
  for (std::int64_t l = 0; l < config.layers; ++l)
    layers->push_back(std::make_shared<nn::ParallelLinear>(
        config.experts, l == 0 ? shape.observation_size : config.width, config.width, gen));
  experts_ = register_module("experts", layers);
  // A bias-free Linear(K -> k) with Xavier-uniform weights, stored [K, k] so that a task's weights are one row.
  const double bound = std::sqrt(6.0 / static_cast<double>(shape.num_tasks + config.experts));
  task_weights_ = register_parameter(
      "task_weights", ag::rand({shape.num_tasks, config.experts}, gen, ag::Dtype::Float32, -bound, bound));
  heads_ = register_module("heads",
                           std::make_shared<nn::ParallelLinear>(shape.num_tasks, config.width, shape.action_size, gen));
}

ag::Tensor MOORE::expert_outputs(const ag::Tensor& observations) {
  const auto& layers = child_at<nn::ModuleList>(experts_);
  ag::Tensor y = observations;  // [n, S], shared by every expert's first layer
  for (std::size_t l = 0; l < layers.size(); ++l) {
    y = layers.at<nn::ParallelLinear>(l).forward(y);
    if (l + 1 < layers.size()) y = ag::relu(y);
  }
  return config_.orthogonal ? ag::gram_schmidt(y) : y;
}

ag::Tensor MOORE::mixed(const ag::Tensor& outputs, const std::vector<std::int64_t>& tasks) {
  const auto n = static_cast<std::int64_t>(tasks.size());
  const ag::Tensor weights = ag::index_select(parameter_at(task_weights_), tasks);                   // [n, k]
  const ag::Tensor per_expert = ag::reshape(ag::transpose(weights, 0, 1), {config_.experts, n, 1});  // [k, n, 1]
  return ag::tanh(ag::sum(ag::mul(outputs, per_expert), {0}));
}

ag::Tensor MOORE::predict(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks,
                          std::int64_t per_task) {
  const ag::Tensor features = mixed(expert_outputs(observations), tasks);  // [n, width]
  auto& heads = child_at<nn::ParallelLinear>(heads_);
  if (per_task > 0) {  // balanced: head k sees only task k's rows
    const ag::Tensor grouped = ag::reshape(features, {shape().num_tasks, per_task, config_.width});
    return ag::reshape(heads.forward(grouped), {-1, shape().action_size});
  }
  return ag::index_select(ag::reshape(heads.forward(features), {-1, shape().action_size}), own_task_rows(tasks));
}

ag::Tensor MOORE::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("MOORE::act", shape(), observations, tasks);
  return predict(observations, tasks, 0);
}

LossTerms MOORE::loss(const Batch& batch) {
  detail::check_batch("MOORE::loss", shape(), batch);
  return detail::bc_terms(bc_loss(predict(batch.observations, batch.tasks, batch.per_task), batch));
}

ag::Tensor MOORE::routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("MOORE::routing", shape(), observations, tasks);
  ag::NoGradGuard no_grad;  // a record, never a loss: no graph back to the task weights
  return detail::task_weight_shares(parameter_at(task_weights_), tasks);
}

double moore_parameter_count(const PolicyShape& shape, const MOOREConfig& c) {
  const double k = static_cast<double>(c.experts), K = static_cast<double>(shape.num_tasks);
  std::vector<std::int64_t> expert(static_cast<std::size_t>(c.layers) + 1, c.width);
  expert.front() = shape.observation_size;
  return k * mlp_parameter_count(expert) + K * k + K * mlp_parameter_count({c.width, shape.action_size});
}

namespace {

MOOREConfig moore_config(const PolicyShape& shape, const MethodOptions& o) {
  MOOREConfig c;
  c.experts = option_int(o.own, "experts");
  c.layers = option_int(o.own, "layers");
  c.orthogonal = o.own.at("orthogonal").get<bool>();
  c.width = option_int(o.own, "width");
  const bool matched = c.width == 0;
  c = with_matched_width(c, &MOOREConfig::width, shape, o, moore_parameter_count);
  if (matched && c.orthogonal) c.width = std::max(c.width, c.experts);
  return c;
}

}  // namespace

PolicyMethod moore_method() {
  PolicyMethod method;
  method.name = "moore";
  method.summary =
      "MOORE: k state-only experts made orthonormal per state (Gram-Schmidt), mixed by task weights, a head per task";
  method.options = {
      io::integer_option("experts", 4, 1, 64, "MOORE's k experts (the paper's MT10 setting; 6 on MT50)"),
      io::integer_option("layers", 3, 1, 16, "layers per expert (ReLU between them, none after the last)"),
      io::integer_option("width", 0, 0, 65536,
                         "every expert layer's width; 0: the width at which MOORE has MAPS's "
                         "parameter count under this config's `maps.*` (the paper: 400)"),
      io::boolean_option("orthogonal", true,
                         "the Gram-Schmidt layer; `false` is the plain mixture of experts MOORE's "
                         "paper compares with"),
  };
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return moore_parameter_count(shape, moore_config(shape, o));
  };
  method.size_keys = "moore.experts, moore.layers and moore.width";
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<MOORE>(shape, moore_config(shape, o), gen);
  };
  return method;
}

}  // namespace maps::core
