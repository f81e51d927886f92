#include "maps/policies/maml.h"

#include <limits>
#include <random>
#include <stdexcept>
#include <string>

#include "maps/data/demo_dataset.h"
#include "maps/policies/policy_registry.h"
#include "nn/mlp.h"

namespace maps::core {

namespace {

// The MLP evaluated at `params` (in named_parameters() order): a parameter-sharing clone with its slots replaced,
// so gradients taken through `params` reach whatever they were computed from.
std::shared_ptr<nn::MLP> evaluated_at(const nn::MLP& mlp, const nn::NamedTensors& names,
                                      const std::vector<ag::Tensor>& params) {
  auto learner = std::static_pointer_cast<nn::MLP>(mlp.clone_sharing_parameters());
  for (std::size_t i = 0; i < params.size(); ++i) learner->replace_parameter(names[i].name, params[i]);
  return learner;
}

std::vector<ag::Tensor> tensors_of(const nn::NamedTensors& named) {
  std::vector<ag::Tensor> out;
  for (const auto& p : named) out.push_back(p.tensor);
  return out;
}

void check_task_rows(const std::string& where, const Batch& batch, int task) {
  for (std::size_t j = 0; j < batch.tasks.size(); ++j)
    if (batch.tasks[j] != task)
      throw std::invalid_argument(where + ": batch " + std::to_string(task) + " must hold only task " +
                                  std::to_string(task) + "'s rows, got task " + std::to_string(batch.tasks[j]) +
                                  " at row " + std::to_string(j));
}

}  // namespace

MAML::MAML(PolicyShape shape, ag::Generator& gen, const MAMLConfig& config,
           const std::vector<std::int64_t>& hidden_sizes, nn::Activation activation)
    : Policy("MAML", shape), config_(config) {
  detail::check_construction("MAML", shape, hidden_sizes, /*need_hidden=*/false);
  if (!(config.inner_lr >= 0.0) || config.inner_steps < 1 || config.query_per_task < 1 || config.finetune_steps < 0)
    throw std::invalid_argument(
        "MAML: expected inner_lr >= 0, inner_steps >= 1, query_per_task >= 1 and "
        "finetune_steps >= 0, got " +
        std::to_string(config.inner_lr) + ", " + std::to_string(config.inner_steps) + ", " +
        std::to_string(config.query_per_task) + ", " + std::to_string(config.finetune_steps));
  policy_ = register_module(
      "policy", std::make_shared<nn::MLP>(detail::layer_sizes(shape.observation_size, hidden_sizes, shape.action_size),
                                          activation, gen));
}

std::int64_t MAML::batch_per_task(std::int64_t states_per_task) const {
  if (states_per_task < 1)
    throw std::invalid_argument("MAML::batch_per_task: expected at least one support state per task, got " +
                                std::to_string(states_per_task));
  support_per_task_ = states_per_task;
  return states_per_task + config_.query_per_task;
}

LossTerms MAML::loss(const Batch& batch) {
  detail::check_balanced_batch("MAML::loss", shape(), batch);
  const std::int64_t per_task = batch.per_task;
  const std::int64_t query = config_.query_per_task;
  const std::int64_t support = per_task - query;
  if (support < 1)
    throw std::invalid_argument("MAML::loss: expected per_task = support + query_per_task (" + std::to_string(query) +
                                ") with at least one support row, got per_task " + std::to_string(per_task));
  support_per_task_ = support;

  auto& mlp = child_at<nn::MLP>(policy_);
  const nn::NamedTensors named = mlp.named_parameters();
  const std::vector<ag::Tensor> theta = tensors_of(named);
  const bool second_order = !config_.first_order;
  ag::Tensor query_sum, support_sum;
  for (std::int64_t k = 0; k < shape().num_tasks; ++k) {
    const std::int64_t start = k * per_task;
    const ag::Tensor xs = ag::narrow(batch.observations, 0, start, support);
    const ag::Tensor ys = ag::narrow(batch.actions, 0, start, support);
    const ag::Tensor xq = ag::narrow(batch.observations, 0, start + support, query);
    const ag::Tensor yq = ag::narrow(batch.actions, 0, start + support, query);
    std::vector<ag::Tensor> params = theta;
    auto learner = evaluated_at(mlp, named, params);
    for (int step = 0; step < config_.inner_steps; ++step) {
      const ag::Tensor support_loss = ag::mse_loss(learner->forward(xs), ys);
      if (step == 0) support_sum = support_sum.defined() ? support_sum + support_loss.detach() : support_loss.detach();
      // retain_graph: in first-order mode a later step's gradient walks back through this step's update, which
      // must stay intact for the query loss's backward.
      const std::vector<ag::Tensor> grads =
          ag::grad({support_loss}, params, {}, /*retain_graph=*/true, /*create_graph=*/second_order);
      for (std::size_t i = 0; i < params.size(); ++i) {
        // First order: a detached gradient makes d theta' / d theta the identity, so the meta-gradient is the
        // query gradient at theta' (FOMAML).
        params[i] = params[i] - config_.inner_lr * (second_order ? grads[i] : grads[i].detach());
        learner->replace_parameter(named[i].name, params[i]);
      }
    }
    const ag::Tensor query_loss = ag::mse_loss(learner->forward(xq), yq);
    query_sum = query_sum.defined() ? query_sum + query_loss : query_loss;
  }
  const double tasks = static_cast<double>(shape().num_tasks);
  const ag::Tensor total = query_sum / tasks;
  return LossTerms{total, {{"query_bc", total}, {"support_bc", support_sum / tasks}}};
}

ag::Tensor MAML::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("MAML::act", shape(), observations, tasks);
  auto& mlp = child_at<nn::MLP>(policy_);
  if (adapted_.empty()) return mlp.forward(observations);

  const nn::NamedTensors named = mlp.named_parameters();
  const ag::Dtype dtype = named.front().tensor.dtype();
  std::vector<std::vector<std::int64_t>> rows(static_cast<std::size_t>(shape().num_tasks));
  for (std::size_t j = 0; j < tasks.size(); ++j)
    rows[static_cast<std::size_t>(tasks[j])].push_back(static_cast<std::int64_t>(j));
  std::vector<ag::Tensor> outputs;
  std::vector<std::int64_t> order;  // the input row of each output row
  for (std::size_t k = 0; k < rows.size(); ++k) {
    if (rows[k].empty()) continue;
    std::vector<ag::Tensor> params;
    // to(dtype) keeps the adaptation valid after Module::to() converted theta.
    for (const ag::Tensor& p : adapted_[k]) params.push_back(p.to(dtype));
    const auto learner = evaluated_at(mlp, named, params);
    const bool all_rows = rows[k].size() == tasks.size();
    outputs.push_back(learner->forward(all_rows ? observations : ag::index_select(observations, rows[k])));
    if (all_rows) return outputs.back();
    order.insert(order.end(), rows[k].begin(), rows[k].end());
  }
  if (outputs.empty()) return mlp.forward(observations);  // no rows
  std::vector<std::int64_t> inverse(order.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    inverse[static_cast<std::size_t>(order[i])] = static_cast<std::int64_t>(i);
  return ag::index_select(ag::concat(outputs, 0), inverse);
}

ag::Tensor MAML::bc_loss(const Batch& batch) {
  detail::check_batch("MAML::bc_loss", shape(), batch);
  return ag::mse_loss(act(batch.observations, batch.tasks), batch.actions);
}

void MAML::clear_adaptation() {
  adapted_.clear();
  adapted_steps_.clear();
  unadapted_validation_loss_.clear();
  adapted_validation_loss_.clear();
}

void MAML::adapt(const std::vector<Batch>& train_per_task, const std::vector<Batch>& valid_per_task) {
  const auto num_tasks = static_cast<std::size_t>(shape().num_tasks);
  if (train_per_task.size() != num_tasks || valid_per_task.size() != num_tasks)
    throw std::invalid_argument("MAML::adapt: expected one training and one validation batch per task (" +
                                std::to_string(num_tasks) + "), got " + std::to_string(train_per_task.size()) +
                                " and " + std::to_string(valid_per_task.size()));
  for (std::size_t k = 0; k < num_tasks; ++k) {
    detail::check_batch("MAML::adapt (training)", shape(), train_per_task[k]);
    check_task_rows("MAML::adapt (training)", train_per_task[k], static_cast<int>(k));
    if (train_per_task[k].size() == 0)
      throw std::invalid_argument("MAML::adapt: the training batch of task " + std::to_string(k) + " is empty");
    detail::check_batch("MAML::adapt (validation)", shape(), valid_per_task[k]);
    check_task_rows("MAML::adapt (validation)", valid_per_task[k], static_cast<int>(k));
  }

  auto& mlp = child_at<nn::MLP>(policy_);
  const nn::NamedTensors named = mlp.named_parameters();
  std::vector<std::vector<ag::Tensor>> adapted(num_tasks);
  std::vector<int> steps(num_tasks, 0);
  std::vector<double> before(num_tasks), after(num_tasks);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t k = 0; k < num_tasks; ++k) {
    const Batch& train = train_per_task[k];
    const Batch& valid = valid_per_task[k];
    const bool has_valid = valid.size() > 0;
    auto valid_loss = [&](const std::vector<ag::Tensor>& params) {
      if (!has_valid) return nan;
      ag::NoGradGuard no_grad;
      return ag::mse_loss(evaluated_at(mlp, named, params)->forward(valid.observations), valid.actions).item();
    };
    std::vector<ag::Tensor> params;
    {
      // Copies, so that later optimiser steps on theta cannot reach the adaptation.
      ag::NoGradGuard no_grad;
      for (const auto& p : named) params.push_back(p.tensor.detach().clone());
    }
    std::vector<ag::Tensor> best = params;
    double best_loss = valid_loss(params);
    before[k] = best_loss;
    for (int step = 1; step <= config_.finetune_steps; ++step) {
      for (ag::Tensor& p : params) p.requires_grad_(true);
      const ag::Tensor loss =
          ag::mse_loss(evaluated_at(mlp, named, params)->forward(train.observations), train.actions);
      const std::vector<ag::Tensor> grads = ag::grad({loss}, params);
      {
        ag::NoGradGuard no_grad;
        for (std::size_t i = 0; i < params.size(); ++i) params[i] = params[i] - config_.inner_lr * grads[i];
      }
      const double v = valid_loss(params);
      if (!has_valid || v < best_loss) {
        best = params;
        best_loss = v;
        steps[k] = step;
      }
    }
    for (ag::Tensor& p : best) p = p.detach();
    adapted[k] = std::move(best);
    after[k] = best_loss;
  }
  adapted_ = std::move(adapted);
  adapted_steps_ = std::move(steps);
  unadapted_validation_loss_ = std::move(before);
  adapted_validation_loss_ = std::move(after);
}

void MAML::prepare_for_evaluation(const DemoDataset& data) {
  if (data.num_tasks() != shape().num_tasks)
    throw std::invalid_argument("MAML::prepare_for_evaluation: expected a dataset of " +
                                std::to_string(shape().num_tasks) + " tasks, got " + std::to_string(data.num_tasks()));
  const ag::Dtype dtype = child_at<nn::MLP>(policy_).parameters().front().dtype();
  std::mt19937_64 rng(config_.finetune_seed);
  std::vector<Batch> train, valid;
  for (int k = 0; k < data.num_tasks(); ++k) {
    const std::int64_t n = support_per_task_ > 0 ? support_per_task_ : data.training_samples(k);
    train.push_back(data.task_training_batch(k, n, rng, dtype));
    valid.push_back(data.task_validation_batch(k, dtype));
  }
  adapt(train, valid);
}

double MAML::validation_loss(const Batch& validation, const DemoDataset& data) {
  if (config_.validate != "adapted") return Policy::validation_loss(validation, data);
  prepare_for_evaluation(data);
  const double loss = mean_action_error(*this, validation);
  clear_adaptation();
  return loss;
}

PolicyMethod maml_method() {
  PolicyMethod method;
  method.name = "maml";
  method.summary =
      "MAML: one MLP meta-trained across tasks, fine-tuned on each before evaluation (maml.*, baselines.hidden)";
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return mlp_parameter_count(detail::layer_sizes(shape.observation_size, o.baseline_hidden, shape.action_size));
  };
  method.size_keys = "baselines.hidden";
  method.uses_baselines_hidden = true;
  method.sampled_bc_loss = false;
  method.not_trained_by_gail = "its adaptation is a BC inner loop";
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<MAML>(shape, gen, o.maml, o.baseline_hidden);
  };
  return method;
}

}  // namespace maps::core
