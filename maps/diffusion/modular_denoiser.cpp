#include "maps/diffusion/modular_denoiser.h"

#include <cmath>
#include <stdexcept>

#include "maps/diffusion/conditional_blocks.h"
#include "maps/policies/maps_policy.h"
#include "maps/policies/policy_registry.h"
#include "nn/mlp.h"
#include "nn/parallel_linear.h"

namespace maps::diffusion {
namespace {

// The modules' layer sizes: a flat denoiser's without its output layer (MAPS's head mixes their features).
std::vector<std::int64_t> module_sizes(const ModularDenoiserConfig& c) {
  std::vector<std::int64_t> sizes =
      flat_denoiser_layer_sizes(c.horizon, c.action_dim, c.step_embed_dim, c.cond_dim, c.module_hidden);
  sizes.pop_back();
  return sizes;
}

}  // namespace

ModularDenoiser::ModularDenoiser(const ModularDenoiserConfig& config, ag::Generator& gen)
    : Denoiser("ModularDenoiser"), config_(config), activation_(nn::activation_from_name(config.activation)) {
  const std::int64_t M = config.modules, out = config.horizon * config.action_dim;
  if (config.horizon < 1 || config.action_dim < 1 || config.state_size < 1 || config.num_tasks < 1 || M < 1 ||
      config.module_hidden.empty() || config.cond_dim < config.state_size + config.num_tasks)
    throw std::invalid_argument(
        "ModularDenoiser: horizon, action size, state size, tasks and modules must be >= 1, "
        "module_hidden not empty, and the condition must hold a state and the task");
  step_embedding_ = register_module("step_embedding", std::make_shared<StepEmbedding>(config.step_embed_dim, gen));
  const std::vector<std::int64_t> sizes = module_sizes(config);
  for (std::size_t i = 0; i + 1 < sizes.size(); ++i)
    module_layers_.push_back(register_module("modules" + std::to_string(i),
                                             std::make_shared<nn::ParallelLinear>(M, sizes[i], sizes[i + 1], gen)));
  const std::int64_t in = sizes.back();
  std::vector<std::int64_t> selector_sizes{config.state_size + config.num_tasks};
  selector_sizes.insert(selector_sizes.end(), config.selector_hidden.begin(), config.selector_hidden.end());
  selector_sizes.push_back(M);
  selector_ = register_module("selector", std::make_shared<nn::MLP>(selector_sizes, activation_, gen));
  core::ScoredHead head = core::make_scored_head(M, in, out, gen);  // as MAPS's
  head_weight_ = register_module("head", head.blocks);
  head_bias_ = register_parameter("head_bias", head.bias);
  for (const auto& [name, weight] : config.selector_losses) {
    if (!(weight >= 0.0) || !std::isfinite(weight))
      throw std::invalid_argument("ModularDenoiser: selector loss '" + name + "' needs a finite weight >= 0");
    losses_.push_back(register_module("loss_" + name, core::make_selector_loss(name)));
    loss_weights_.push_back(weight);
  }
}

ag::Tensor ModularDenoiser::selector_scores(const ag::Tensor& states, const ag::Tensor& one_hot_tasks) {
  return ag::softmax(child_at<nn::MLP>(selector_).forward(ag::concat({states, one_hot_tasks}, 1)), 1);
}

ag::Tensor ModularDenoiser::scores(const ag::Tensor& states, const std::vector<std::int64_t>& tasks) {
  return selector_scores(states, ag::one_hot(tasks, config_.num_tasks, states.dtype()));
}

ag::Tensor ModularDenoiser::forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) {
  const std::int64_t n = noisy.size(0), M = config_.modules;
  const ag::Tensor x = flat_denoiser_input("ModularDenoiser", noisy, steps, cond, config_.horizon, config_.action_dim,
                                           config_.cond_dim, child_at<StepEmbedding>(step_embedding_));
  ag::Tensor h = x;
  for (std::size_t slot : module_layers_) h = child_at<nn::ParallelLinear>(slot).forward_activated(h, activation_);
  const ag::Tensor g = selector_scores(ag::narrow(cond, 1, 0, config_.state_size),
                                       ag::narrow(cond, 1, config_.cond_dim - config_.num_tasks, config_.num_tasks));
  const ag::Tensor per_module = child_at<nn::ParallelLinear>(head_weight_).forward(h);  // [M, n, out]
  const ag::Tensor mixed = ag::sum(per_module * g.t().reshape({M, n, 1}), {0}) + parameter_at(head_bias_);
  return ag::reshape(mixed, {n, config_.horizon, config_.action_dim});
}

core::LossTerms ModularDenoiser::selector_terms(const ag::Tensor& states, const ag::Tensor& previous_states,
                                                const std::vector<std::int64_t>& tasks) {
  core::LossTerms result;
  if (losses_.empty()) return result;
  const std::int64_t n = states.size(0), K = config_.num_tasks, M = config_.modules;
  core::SelectorOutputs out;
  out.tasks = tasks;
  out.num_tasks = K;
  out.num_modules = M;
  // Every state under every task, task-major (row k n + j), for the share loss; the own-task rows are among them.
  std::vector<ag::Tensor> repeated(static_cast<std::size_t>(K), states);
  std::vector<std::int64_t> every_task;
  for (std::int64_t k = 0; k < K; ++k) every_task.insert(every_task.end(), static_cast<std::size_t>(n), k);
  const ag::Tensor all = scores(ag::concat(repeated, 0), every_task);
  out.all_task_scores = all.reshape({K, n, M});
  out.scores = ag::index_select(all, core::own_task_rows(tasks));
  out.previous_scores = scores(previous_states, tasks);
  ag::Tensor total = ag::zeros({}, states.dtype());
  for (std::size_t j = 0; j < losses_.size(); ++j) {
    auto& loss = child_at<core::SelectorLoss>(losses_[j]);
    const ag::Tensor value = loss.forward(out);
    result.terms.emplace_back(loss.name(), value);
    total = total + value * loss_weights_[j];
  }
  result.total = total;
  return result;
}

double modular_denoiser_parameter_count(const ModularDenoiserConfig& c) {
  std::vector<std::int64_t> selector_sizes{c.state_size + c.num_tasks};
  selector_sizes.insert(selector_sizes.end(), c.selector_hidden.begin(), c.selector_hidden.end());
  selector_sizes.push_back(c.modules);
  const double out = static_cast<double>(c.horizon * c.action_dim);
  return step_embedding_parameter_count(c.step_embed_dim) +
         static_cast<double>(c.modules) * core::mlp_parameter_count(module_sizes(c)) +
         core::mlp_parameter_count(selector_sizes) + static_cast<double>(c.modules * c.module_hidden.back()) * out +
         out;
}

}  // namespace maps::diffusion
