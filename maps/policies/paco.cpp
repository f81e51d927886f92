#include "maps/policies/paco.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy_registry.h"
#include "nn/module_list.h"
#include "nn/parallel_linear.h"

namespace maps::core {
namespace {

// Writes row-major values into a parameter's storage whatever its dtype (float32 in training, float64 in checks).
void assign(const ag::Tensor& tensor, const std::vector<double>& values) {
  ag::NoGradGuard no_grad;
  if (tensor.dtype() == ag::Dtype::Float32) {
    float* data = const_cast<ag::Tensor&>(tensor).data<float>();
    for (std::size_t i = 0; i < values.size(); ++i) data[i] = static_cast<float>(values[i]);
  } else {
    double* data = const_cast<ag::Tensor&>(tensor).data<double>();
    std::copy(values.begin(), values.end(), data);
  }
}

// Every member of a [P, ...] parameter set to member 0's values.
void copy_first_member(const ag::Tensor& tensor) {
  std::vector<double> values = tensor.to_vector();
  const std::size_t member = values.size() / static_cast<std::size_t>(tensor.size(0));
  for (std::size_t i = member; i < values.size(); ++i) values[i] = values[i % member];
  assign(tensor, values);
}

}  // namespace

PaCo::PaCo(PolicyShape shape, const PaCoConfig& config, ag::Generator& gen) : Policy("PaCo", shape), config_(config) {
  detail::check_construction("PaCo", shape, {config.width}, /*need_hidden=*/true);
  if (config.parameter_sets < 1 || config.layers < 1)
    throw std::invalid_argument("PaCo: parameter_sets and layers must be >= 1, got " +
                                std::to_string(config.parameter_sets) + " and " + std::to_string(config.layers));
  if (config.reset != "interpolate" && config.reset != "copy")
    throw std::invalid_argument("PaCo: reset must be \"interpolate\" or \"copy\", got \"" + config.reset + "\"");
  const std::vector<std::int64_t> sizes = detail::layer_sizes(
      shape.observation_size, std::vector<std::int64_t>(config.layers, config.width), shape.action_size);
  auto layers = std::make_shared<nn::ModuleList>();
  for (std::size_t l = 0; l + 1 < sizes.size(); ++l) {
    auto layer = std::make_shared<nn::ParallelLinear>(config.parameter_sets, sizes[l], sizes[l + 1], gen);
    if (config.identical_init) {
      copy_first_member(layer->weight());
      copy_first_member(layer->bias());
    }
    layers->push_back(layer);
  }
  sets_ = register_module("sets", layers);
  // The task encoder is a Linear(K -> P) initialised as PyTorch initialises one (uniform, bound 1/sqrt(K)); PaCo's
  // public code builds it with ALF, whose initialisation the reference notes do not record. Its weight is stored
  // [K, P] so that a task's weights are a row.
  const double bound = 1.0 / std::sqrt(static_cast<double>(shape.num_tasks));
  task_weights_ = register_parameter(
      "task_weights", ag::rand({shape.num_tasks, config.parameter_sets}, gen, ag::Dtype::Float32, -bound, bound));
  task_bias_ =
      register_parameter("task_bias", ag::rand({config.parameter_sets}, gen, ag::Dtype::Float32, -bound, bound));
}

ag::Tensor PaCo::task_weights() const { return ag::add(parameter_at(task_weights_), parameter_at(task_bias_)); }

ag::Tensor PaCo::run(const ag::Tensor& x) {
  const ag::Tensor w = task_weights();  // [K, P]
  const auto& layers = child_at<nn::ModuleList>(sets_);
  const std::int64_t K = shape().num_tasks, P = config_.parameter_sets;
  ag::Tensor y = x;
  for (std::size_t l = 0; l < layers.size(); ++l) {
    const auto& layer = layers.at<nn::ParallelLinear>(l);
    const std::int64_t in = layer.in_features(), out = layer.out_features();
    // theta_k = sum_p w_{k,p} phi_p for every task at once: [K, P] x [P, in * out].
    const ag::Tensor weight = ag::reshape(ag::matmul(w, ag::reshape(layer.weight(), {P, in * out})), {K, in, out});
    const ag::Tensor bias = ag::reshape(ag::matmul(w, ag::reshape(layer.bias(), {P, out})), {K, 1, out});
    y = ag::parallel_linear(y, weight, bias);
    if (l + 1 < layers.size()) y = ag::relu(y);
  }
  return y;
}

ag::Tensor PaCo::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("PaCo::act", shape(), observations, tasks);
  return ag::index_select(ag::reshape(run(observations), {-1, shape().action_size}), own_task_rows(tasks));
}

LossTerms PaCo::loss(const Batch& batch) {
  detail::check_batch("PaCo::loss", shape(), batch);
  const std::int64_t K = shape().num_tasks, A = shape().action_size;
  const ag::Tensor prediction =
      batch.per_task > 0
          ? ag::reshape(run(ag::reshape(batch.observations, {K, batch.per_task, shape().observation_size})), {-1, A})
          : ag::index_select(ag::reshape(run(batch.observations), {-1, A}), own_task_rows(batch.tasks));
  masked_.clear();
  reset_seed_ = batch.noise_seed;
  if (config_.mask_threshold > 0.0) {
    std::vector<double> task_loss(static_cast<std::size_t>(K), 0.0), rows(static_cast<std::size_t>(K), 0.0);
    {
      ag::NoGradGuard no_grad;
      const auto row_error = ag::mean(ag::square(prediction - batch.actions), {1}).to_vector();
      for (std::size_t j = 0; j < row_error.size(); ++j) {
        task_loss[static_cast<std::size_t>(batch.tasks[j])] += row_error[j];
        rows[static_cast<std::size_t>(batch.tasks[j])] += 1.0;
      }
    }
    for (std::int64_t k = 0; k < K; ++k)
      if (rows[static_cast<std::size_t>(k)] > 0 &&
          !(task_loss[static_cast<std::size_t>(k)] / rows[static_cast<std::size_t>(k)] <= config_.mask_threshold))
        masked_.push_back(k);
  }
  ag::Tensor bc;
  if (masked_.empty()) {
    bc = bc_loss(prediction, batch);
  } else {
    std::vector<std::int64_t> kept;
    for (std::size_t j = 0; j < batch.tasks.size(); ++j)
      if (std::find(masked_.begin(), masked_.end(), batch.tasks[j]) == masked_.end())
        kept.push_back(static_cast<std::int64_t>(j));
    if (kept.empty()) {
      bc = ag::mul(ag::sum(prediction), 0.0);  // every task masked: no step, but a graph to step through
    } else {
      Batch healthy;
      healthy.actions = ag::index_select(batch.actions, kept);
      healthy.noise_seed = batch.noise_seed;
      // The masked rows' loss is 0 and the mean still runs over the whole batch, as the public code zeroes the
      // masked samples' loss: a masked step is not scaled up.
      bc = bc_loss(ag::index_select(prediction, kept), healthy) *
           (static_cast<double>(kept.size()) / static_cast<double>(batch.tasks.size()));
    }
  }
  return LossTerms{
      bc, {{"bc", bc}, {"masked_tasks", ag::scalar_tensor(static_cast<double>(masked_.size()), prediction.dtype())}}};
}

void PaCo::after_step() {
  if (masked_.empty()) return;
  const std::int64_t K = shape().num_tasks, P = config_.parameter_sets;
  std::vector<std::int64_t> healthy;
  for (std::int64_t k = 0; k < K; ++k)
    if (std::find(masked_.begin(), masked_.end(), k) == masked_.end()) healthy.push_back(k);
  if (healthy.empty()) return;  // nothing to reset towards
  // The reset acts on the encoder's weight column of the task (w_k = W e_k + b, the bias shared), as the public code
  // resets the task's column of the task-encoding weight.
  std::vector<double> w = parameter_at(task_weights_).to_vector();
  ag::Generator gen(reset_seed_ ^ 0x7061636fULL);
  for (const std::int64_t k : masked_) {
    std::vector<double> mix(healthy.size(), 0.0);
    if (config_.reset == "copy") {
      mix[static_cast<std::size_t>(gen.engine()() % healthy.size())] = 1.0;
    } else {
      const auto draws = ag::rand({static_cast<std::int64_t>(healthy.size())}, gen, ag::Dtype::Float64).to_vector();
      double total = 0.0;
      for (double d : draws) total += d;
      for (std::size_t h = 0; h < healthy.size(); ++h) mix[h] = draws[h] / total;
    }
    for (std::int64_t p = 0; p < P; ++p) {
      double value = 0.0;
      for (std::size_t h = 0; h < healthy.size(); ++h)
        value += mix[h] * w[static_cast<std::size_t>(healthy[h] * P + p)];
      w[static_cast<std::size_t>(k * P + p)] = value;
    }
  }
  assign(parameter_at(task_weights_), w);
  masked_.clear();
}

ag::Tensor PaCo::routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("PaCo::routing", shape(), observations, tasks);
  ag::NoGradGuard no_grad;
  return detail::task_weight_shares(task_weights(), tasks);
}

double paco_parameter_count(const PolicyShape& shape, const PaCoConfig& c) {
  const double P = static_cast<double>(c.parameter_sets);
  return P * mlp_parameter_count(detail::layer_sizes(shape.observation_size,
                                                     std::vector<std::int64_t>(c.layers, c.width), shape.action_size)) +
         static_cast<double>(shape.num_tasks) * P + P;
}

namespace {

PaCoConfig paco_config(const PolicyShape& shape, const MethodOptions& o) {
  PaCoConfig c;
  c.parameter_sets = option_int(o.own, "parameter_sets");
  c.layers = option_int(o.own, "layers");
  c.identical_init = o.own.at("identical_init").get<bool>();
  c.mask_threshold = o.own.at("mask_threshold").get<double>();
  c.reset = o.own.at("reset").get<std::string>();
  c.width = option_int(o.own, "width");
  return with_matched_width(c, &PaCoConfig::width, shape, o, paco_parameter_count);
}

}  // namespace

PolicyMethod paco_method() {
  PolicyMethod method;
  method.name = "paco";
  method.summary = "PaCo: every layer a task-weighted sum of P parameter sets (theta_k = Phi w_k), loss masking";
  method.options = {
      io::integer_option("parameter_sets", 5, 1, 64,
                         "PaCo's P parameter sets per layer (the public code's MT10 setting)"),
      io::integer_option("layers", 3, 1, 16, "hidden layers (ReLU), each compositional, as is the output layer"),
      io::integer_option("width", 0, 0, 65536,
                         "hidden width; 0: matched to MAPS's parameter count (the public code's "
                         "widths live in a config the repository does not include)"),
      io::boolean_option("identical_init", true,
                         "every parameter set starts as the first (the public code's "
                         "`use_identical_init`)"),
      io::number_option("mask_threshold", 30.0, 0.0, 1e12,
                        "a task whose mean BC loss in the batch exceeds this is left out of the step "
                        "and its task weights are reset after it (0: never); the public code's 3e3 "
                        "is an RL loss scale"),
      io::choice_option("reset", "interpolate", {"interpolate", "copy"},
                        "a masked task's new weights: a random convex combination of the other "
                        "tasks' (`interpolate`) or one of them (`copy`)"),
  };
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return paco_parameter_count(shape, paco_config(shape, o));
  };
  method.size_keys = "paco.parameter_sets, paco.layers and paco.width";
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<PaCo>(shape, paco_config(shape, o), gen);
  };
  return method;
}

}  // namespace maps::core
