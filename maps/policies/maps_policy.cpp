#include "maps/policies/maps_policy.h"

#include <cmath>
#include <numeric>
#include <stdexcept>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy_registry.h"
#include "nn/linear.h"

namespace maps::core {

bool is_selector_kind(const std::string& kind) { return kind == "learned" || kind == "uniform" || kind == "task"; }

ScoredHead make_scored_head(std::int64_t modules, std::int64_t features, std::int64_t outputs, ag::Generator& gen) {
  auto blocks = std::make_shared<nn::ParallelLinear>(modules, features, outputs, gen, /*bias=*/false);
  const double bound = 1.0 / std::sqrt(static_cast<double>(modules * features));
  blocks->weight().detach().copy_(ag::rand(blocks->weight().shape(), gen, ag::Dtype::Float32, -bound, bound));
  return {blocks, ag::rand({outputs}, gen, ag::Dtype::Float32, -bound, bound)};
}

MAPSPolicy::MAPSPolicy(PolicyShape shape, const MAPSConfig& config, ag::Generator& gen)
    : Policy("MAPSPolicy", shape), config_(config), activation_(nn::activation_from_name(config.activation)) {
  const std::int64_t S = shape.observation_size, A = shape.action_size, K = shape.num_tasks, M = config.modules;
  if (S < 1 || A < 1 || K < 1)
    throw std::invalid_argument("MAPSPolicy: observation, action sizes and task count must be >= 1");
  if (M < 1) throw std::invalid_argument("MAPSPolicy: modules must be >= 1, got " + std::to_string(M));
  if (config.module_hidden.empty()) throw std::invalid_argument("MAPSPolicy: module_hidden must name >= 1 layer");
  std::int64_t in = S;
  for (std::size_t i = 0; i < config.module_hidden.size(); ++i) {
    module_layers_.push_back(register_module(
        "modules" + std::to_string(i), std::make_shared<nn::ParallelLinear>(M, in, config.module_hidden[i], gen)));
    in = config.module_hidden[i];
  }
  std::vector<std::int64_t> selector_sizes{S + K};
  selector_sizes.insert(selector_sizes.end(), config.selector_hidden.begin(), config.selector_hidden.end());
  selector_sizes.push_back(M);
  if (config.observations != "standardized" && config.observations != "raw_clipped")
    throw std::invalid_argument("MAPSPolicy: observations must be \"standardized\" or \"raw_clipped\", got \"" +
                                config.observations + "\"");
  if (raw_inputs()) {
    observation_mean_ = register_buffer("observation_mean", ag::zeros({S}));
    observation_std_ = register_buffer("observation_std", ag::ones({S}));
  }
  if (!is_selector_kind(config.selector))
    throw std::invalid_argument(std::string("MAPSPolicy: selector must be ") + kSelectorKinds + ", got \"" +
                                config.selector + "\"");
  // Drawn either way, so that the modules and the head start from the same numbers for a seed.
  auto selector = std::make_shared<nn::MLP>(selector_sizes, activation_, gen);
  if (!uniform_selector()) selector_ = register_module("selector", selector);
  // As M blocks: head = sum_i g_i (v_i W_i) + b is one batched matmul and needs no transposing copy.
  ScoredHead head = make_scored_head(M, in, A, gen);
  head_weight_ = register_module("head", head.blocks);
  head_bias_ = register_parameter("head_bias", head.bias);
  for (const auto& [name, weight] : config.selector_losses) {
    if (uniform_selector()) break;  // constant under uniform scores
    if (!(weight >= 0.0) || !std::isfinite(weight))
      throw std::invalid_argument("MAPSPolicy: selector loss '" + name + "' needs a finite weight >= 0");
    losses_.push_back(register_module("loss_" + name, make_selector_loss(name)));
    loss_weights_.push_back(weight);
  }
}

void MAPSPolicy::set_observation_statistics(const Eigen::VectorXd& mean, const Eigen::VectorXd& std) {
  if (!raw_inputs()) return;
  const std::int64_t S = shape().observation_size;
  if (mean.size() != S || std.size() != S)
    throw std::invalid_argument("MAPSPolicy::set_observation_statistics: expected " + std::to_string(S) +
                                " means and stds, got " + std::to_string(mean.size()) + " and " +
                                std::to_string(std.size()));
  ag::Tensor m = buffer_at(observation_mean_), d = buffer_at(observation_std_);
  m.detach().copy_(ag::from_vector(std::vector<double>(mean.data(), mean.data() + S), {S}, m.dtype()));
  d.detach().copy_(ag::from_vector(std::vector<double>(std.data(), std.data() + S), {S}, d.dtype()));
}

ag::Tensor MAPSPolicy::selector_inputs(const ag::Tensor& observations) const {
  if (!raw_inputs()) return observations;
  const ag::Tensor& mean = buffer_at(observation_mean_);
  const ag::Tensor& std = buffer_at(observation_std_);
  return observations * std.to(observations.dtype()) + mean.to(observations.dtype());
}

ag::Tensor MAPSPolicy::module_inputs(const ag::Tensor& observations) const {
  return raw_inputs() ? ag::clamp(selector_inputs(observations), -5.0, 5.0) : observations;
}

ag::Tensor MAPSPolicy::features(const ag::Tensor& standardized) {
  const ag::Tensor observations = module_inputs(standardized);
  if (const auto fused = nn::fused_activation(activation_)) {  // the whole stack as one op, module by module
    std::vector<ag::Tensor> weights, biases;
    for (std::size_t slot : module_layers_) {
      const auto& layer = child_at<nn::ParallelLinear>(slot);
      weights.push_back(layer.weight());
      biases.push_back(layer.bias());
    }
    return ag::parallel_mlp(observations, weights, biases, *fused);
  }
  ag::Tensor h = observations;
  for (std::size_t slot : module_layers_) h = child_at<nn::ParallelLinear>(slot).forward_activated(h, activation_);
  return h;
}

MAPSPolicy::SelectorFirstLayer MAPSPolicy::selector_first_layer() {
  const std::int64_t S = shape().observation_size, K = shape().num_tasks;
  nn::Linear& first = child_at<nn::MLP>(selector_).layer(0);
  const ag::Tensor& w = first.weight();  // [H, S + K]
  ag::Tensor task_rows = ag::narrow(w, 1, S, K).t();
  if (first.has_bias()) task_rows = task_rows + first.bias();
  return {ag::narrow(w, 1, 0, S), task_rows};
}

ag::Tensor MAPSPolicy::selector_state_parts(const ag::Tensor& observations, const ag::Tensor& state_weight) const {
  if (task_selector()) return ag::zeros({observations.size(0), state_weight.size(0)}, observations.dtype());
  return ag::linear(selector_inputs(observations), state_weight);
}

ag::Tensor MAPSPolicy::selector_logits(const ag::Tensor& state_parts, const std::vector<std::int64_t>& state_rows,
                                       const ag::Tensor& task_rows, const std::vector<std::int64_t>& tasks) {
  auto& selector = child_at<nn::MLP>(selector_);
  if (selector.num_layers() == 1) return ag::gather_add(state_parts, state_rows, task_rows, tasks);
  const auto fused = nn::fused_activation(activation_);
  const ag::Tensor hidden =
      fused ? ag::gather_add(state_parts, state_rows, task_rows, tasks, *fused)
            : nn::apply_activation(activation_, ag::gather_add(state_parts, state_rows, task_rows, tasks));
  return selector.forward_from(1, hidden);
}

ag::Tensor MAPSPolicy::scores(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("MAPSPolicy::scores", shape(), observations, tasks);
  return evaluation_scores(observations, tasks);
}

void MAPSPolicy::force_module(std::int64_t module) {
  if (module < -1 || module >= config_.modules)
    throw std::invalid_argument("MAPSPolicy::force_module: module " + std::to_string(module) + " is not one of 0.." +
                                std::to_string(config_.modules - 1) + " (or -1: none)");
  forced_module_ = module;
}

ag::Tensor MAPSPolicy::evaluation_scores(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  if (forced_module_ < 0) return checked_scores(observations, tasks);
  return ag::one_hot(std::vector<std::int64_t>(tasks.size(), forced_module_), config_.modules, observations.dtype());
}

ag::Tensor MAPSPolicy::checked_scores(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  if (uniform_selector())
    return ag::full({observations.size(0), config_.modules}, 1.0 / static_cast<double>(config_.modules),
                    observations.dtype());
  const auto [state_weight, task_rows] = selector_first_layer();
  std::vector<std::int64_t> rows(tasks.size());
  std::iota(rows.begin(), rows.end(), std::int64_t{0});
  return ag::softmax(selector_logits(selector_state_parts(observations, state_weight), rows, task_rows, tasks), 1);
}

ag::Tensor MAPSPolicy::head(const ag::Tensor& features, const ag::Tensor& scores) {
  const std::int64_t M = features.size(0), n = features.size(1);
  const ag::Tensor per_module = child_at<nn::ParallelLinear>(head_weight_).forward(features);  // [M, n, A]
  const ag::Tensor weights = scores.t().reshape({M, n, 1});
  return ag::sum(per_module * weights, {0}) + parameter_at(head_bias_);
}

ag::Tensor MAPSPolicy::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("MAPSPolicy::act", shape(), observations, tasks);
  return head(features(observations), evaluation_scores(observations, tasks));
}

LossTerms MAPSPolicy::loss(const Batch& batch) {
  const PolicyForward forward = forward_terms(batch);
  const ag::Tensor bc = bc_loss(forward.mean_actions, batch);
  LossTerms result;
  result.terms.emplace_back("bc", bc);
  result.terms.insert(result.terms.end(), forward.regularizer.terms.begin(), forward.regularizer.terms.end());
  result.total = bc * config_.bc_weight;
  if (forward.regularizer.total.defined()) result.total = result.total + forward.regularizer.total;
  return result;
}

PolicyForward MAPSPolicy::forward_terms(const Batch& batch) {
  const ag::Tensor& obs = batch.observations;
  detail::check_batch("MAPSPolicy::loss", shape(), batch);
  detail::check_observations("MAPSPolicy::loss (previous_observations)", shape(), batch.previous_observations,
                             batch.tasks);
  PolicyForward result;
  if (uniform_selector()) {
    result.mean_actions = head(features(obs), checked_scores(obs, batch.tasks));
    return result;
  }
  const std::int64_t n = obs.size(0), K = shape().num_tasks, M = config_.modules;
  SelectorOutputs out;
  out.tasks = batch.tasks;
  out.num_tasks = K;
  out.num_modules = M;
  // One selector pass scores every state under every task (the share loss needs them all; the states' own-task
  // scores are rows of it) and the previous states under their own tasks. The first layer's state part is computed
  // once per state, then each task's row is added (PAPER.md's G(s, k) on [s, one_hot(k)], factored).
  const auto [state_weight, task_rows] = selector_first_layer();  // [H, S], [K, H]
  const ag::Tensor state_parts = selector_state_parts(ag::concat({obs, batch.previous_observations}, 0), state_weight);
  // Rows 0..Kn-1: state j under task k at k n + j; rows Kn..(K+1)n-1: the previous states under their own tasks.
  std::vector<std::int64_t> state_rows, row_tasks;
  state_rows.reserve(static_cast<std::size_t>((K + 1) * n));
  row_tasks.reserve(static_cast<std::size_t>((K + 1) * n));
  for (std::int64_t k = 0; k < K; ++k) {
    for (std::int64_t j = 0; j < n; ++j) state_rows.push_back(j);
    row_tasks.insert(row_tasks.end(), static_cast<std::size_t>(n), k);
  }
  for (std::int64_t j = 0; j < n; ++j) state_rows.push_back(n + j);
  row_tasks.insert(row_tasks.end(), batch.tasks.begin(), batch.tasks.end());
  const ag::Tensor scored = ag::softmax(selector_logits(state_parts, state_rows, task_rows, row_tasks), 1);
  const ag::Tensor all = ag::narrow(scored, 0, 0, K * n);
  out.all_task_scores = all.reshape({K, n, M});
  out.scores = ag::index_select(all, own_task_rows(batch.tasks));
  out.previous_scores = ag::narrow(scored, 0, K * n, n);

  result.mean_actions = head(features(obs), out.scores);
  ag::Tensor selector_total = ag::zeros({}, obs.dtype());
  for (std::size_t j = 0; j < losses_.size(); ++j) {
    auto& loss = child_at<SelectorLoss>(losses_[j]);
    const ag::Tensor value = loss.forward(out);
    result.regularizer.terms.emplace_back(loss.name(), value);
    selector_total = selector_total + value * loss_weights_[j];
  }
  result.regularizer.total = selector_total * config_.selector_weight;
  return result;
}

PolicyMethod maps_method() {
  PolicyMethod method;
  method.name = "maps";
  method.summary = "MAPS: M state-only modules scored by a selector G(s, k), a head over the scored features (maps.*)";
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return maps_parameter_count(shape, o.maps);
  };
  method.size_keys = "maps.modules, maps.module_hidden and maps.selector_hidden";
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<MAPSPolicy>(shape, o.maps, gen);
  };
  return method;
}

}  // namespace maps::core
