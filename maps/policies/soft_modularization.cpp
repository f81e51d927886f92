#include "maps/policies/soft_modularization.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy_registry.h"
#include "nn/init.h"
#include "nn/linear.h"
#include "nn/mlp.h"
#include "nn/module_list.h"
#include "nn/parallel_linear.h"

namespace maps::core {
namespace {

// The official code's basic_init: weight U(+-1/sqrt(out)), bias 0.1 (SoftModularizationConfig::init).
void official_hidden_init(ag::Tensor weight, ag::Tensor bias, std::int64_t out, ag::Generator& gen) {
  const double bound = 1.0 / std::sqrt(static_cast<double>(out));
  nn::init::uniform_(weight, -bound, bound, gen);
  nn::init::constant_(bias, 0.1);
}

// The official code's uniform_init: weight and bias U(+-3e-3).
void official_last_init(nn::Linear& layer, ag::Generator& gen) {
  ag::Tensor weight = layer.weight(), bias = layer.bias();
  nn::init::uniform_(weight, -3e-3, 3e-3, gen);
  nn::init::uniform_(bias, -3e-3, 3e-3, gen);
}

void official_hidden_init(nn::Linear& layer, ag::Generator& gen) {
  official_hidden_init(layer.weight(), layer.bias(), layer.out_features(), gen);
}

void official_hidden_init(nn::MLP& mlp, ag::Generator& gen) {
  for (std::size_t i = 0; i < mlp.num_layers(); ++i) official_hidden_init(mlp.layer(i), gen);
}

void check_init(const std::string& init, const std::string& where) {
  if (init != "official" && init != "pytorch")
    throw std::invalid_argument(where +
                                ": expected \"official\" (the official code's initialisation) or \"pytorch\" "
                                "(torch.nn.Linear's), got \"" +
                                init + "\"");
}

}  // namespace

SoftModularization::SoftModularization(PolicyShape shape, const SoftModularizationConfig& config, ag::Generator& gen)
    : Policy("SoftModularization", shape), config_(config) {
  detail::check_construction("SoftModularization", shape,
                             {config.module_width, config.base_width, config.gating_width, config.modules}, true);
  if (config.module_layers < 2)
    throw std::invalid_argument("SoftModularization: module_layers must be >= 2 (one routing matrix at least), got " +
                                std::to_string(config.module_layers));
  if (config.aggregation != "softmax" && config.aggregation != "sum" && config.aggregation != "mean")
    throw std::invalid_argument("SoftModularization: aggregation must be \"softmax\", \"sum\" or \"mean\", got \"" +
                                config.aggregation + "\"");
  check_init(config.init, "SoftModularization: init");
  const std::int64_t L = config.module_layers, n = config.modules, d = config.module_width, B = config.base_width,
                     G = config.gating_width;
  base_ = register_module("base", std::make_shared<nn::MLP>(std::vector<std::int64_t>{shape.observation_size, B, B},
                                                            nn::Activation::ReLU, gen));
  embedding_ = register_module("embedding", std::make_shared<nn::Linear>(shape.num_tasks, B, gen));
  gating_ = register_module("gating",
                            std::make_shared<nn::MLP>(std::vector<std::int64_t>{B, G, G}, nn::Activation::ReLU, gen));
  auto down = std::make_shared<nn::ModuleList>(), up = std::make_shared<nn::ModuleList>();
  for (std::int64_t l = 1; l < L; ++l) down->push_back(std::make_shared<nn::Linear>(G, n * n, gen));
  for (std::int64_t l = 2; l < L; ++l) up->push_back(std::make_shared<nn::Linear>(n * n * (l - 1), G, gen));
  const bool weighted = config.aggregation == "softmax";
  if (weighted) up->push_back(std::make_shared<nn::Linear>(n * n * (L - 1), G, gen));
  down_ = register_module("down", down);
  up_ = register_module("up", up);
  if (weighted) last_ = register_module("last", std::make_shared<nn::Linear>(G, n, gen));
  auto layers = std::make_shared<nn::ModuleList>();
  for (std::int64_t l = 0; l < L; ++l)
    layers->push_back(std::make_shared<nn::ParallelLinear>(n, l == 0 ? B : d, d, gen));
  module_layers_ = register_module("modules", layers);
  output_ = register_module("output", std::make_shared<nn::Linear>(d, shape.action_size, gen));
  if (config.init == "official") {
    // Redrawn in a fixed order after construction, so "pytorch" keeps the draws it always had.
    official_hidden_init(child_at<nn::MLP>(base_), gen);
    official_hidden_init(child_at<nn::Linear>(embedding_), gen);
    official_hidden_init(child_at<nn::MLP>(gating_), gen);
    for (std::size_t i = 0; i < down->size(); ++i) official_last_init(down->at<nn::Linear>(i), gen);
    for (std::size_t i = 0; i < up->size(); ++i) official_hidden_init(up->at<nn::Linear>(i), gen);
    if (weighted) official_last_init(child_at<nn::Linear>(last_), gen);
    for (std::size_t i = 0; i < layers->size(); ++i) {
      auto& layer = layers->at<nn::ParallelLinear>(i);
      official_hidden_init(layer.weight(), layer.bias(), d, gen);
    }
    official_last_init(child_at<nn::Linear>(output_), gen);
  }
}

SoftModularization::Forward SoftModularization::run(const ag::Tensor& observations,
                                                    const std::vector<std::int64_t>& tasks) {
  const std::int64_t N = observations.size(0), L = config_.module_layers, n = config_.modules;
  const ag::Tensor f = child_at<nn::MLP>(base_).forward(observations);  // [N, B]
  const ag::Tensor e =
      child_at<nn::Linear>(embedding_).forward(ag::one_hot(tasks, shape().num_tasks, observations.dtype()));
  const ag::Tensor g = child_at<nn::MLP>(gating_).forward(ag::relu(f * e));  // [N, G]
  const auto& down = child_at<nn::ModuleList>(down_);
  const auto& up = child_at<nn::ModuleList>(up_);
  Forward out;
  std::vector<ag::Tensor> flat;  // the softmaxed matrices so far, [N, n * n] each
  for (std::int64_t l = 1; l < L; ++l) {
    ag::Tensor hidden = ag::relu(g);
    if (l > 1) hidden = ag::relu(up.at<nn::Linear>(static_cast<std::size_t>(l - 2)).forward(ag::concat(flat, 1)) * g);
    const ag::Tensor logits = down.at<nn::Linear>(static_cast<std::size_t>(l - 1)).forward(hidden);
    const ag::Tensor p = ag::softmax(ag::reshape(logits, {N, n, n}), 2);  // over the source modules
    out.probabilities.push_back(p);
    flat.push_back(ag::reshape(p, {N, n * n}));
  }
  ag::Tensor final_weights;  // [N, n]
  if (config_.aggregation == "softmax") {
    const ag::Tensor c = up.at<nn::Linear>(static_cast<std::size_t>(L - 2)).forward(ag::concat(flat, 1));
    final_weights = ag::softmax(child_at<nn::Linear>(last_).forward(ag::relu(c * g)), 1);
  } else {
    final_weights =
        ag::full({N, n}, config_.aggregation == "sum" ? 1.0 : 1.0 / static_cast<double>(n), observations.dtype());
  }
  out.probabilities.push_back(final_weights);
  const auto& layers = child_at<nn::ModuleList>(module_layers_);
  ag::Tensor x = layers.at<nn::ParallelLinear>(0).forward(ag::relu(f));  // [n, N, d]
  for (std::int64_t l = 1; l < L; ++l) {
    // sum_j p_ij x_j for every row: [N, n, n] x [N, n, d].
    const ag::Tensor mixed =
        ag::transpose(ag::matmul(out.probabilities[static_cast<std::size_t>(l - 1)], ag::transpose(x, 0, 1)), 0, 1);
    x = layers.at<nn::ParallelLinear>(static_cast<std::size_t>(l)).forward(ag::relu(mixed));
  }
  const ag::Tensor weights = ag::reshape(ag::transpose(final_weights, 0, 1), {n, N, 1});
  out.actions = child_at<nn::Linear>(output_).forward(ag::relu(ag::sum(x * weights, {0})));
  return out;
}

ag::Tensor SoftModularization::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("SoftModularization::act", shape(), observations, tasks);
  return run(observations, tasks).actions;
}

LossTerms SoftModularization::loss(const Batch& batch) {
  detail::check_batch("SoftModularization::loss", shape(), batch);
  return detail::bc_terms(bc_loss(run(batch.observations, batch.tasks).actions, batch));
}

ag::Tensor SoftModularization::routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("SoftModularization::routing", shape(), observations, tasks);
  ag::NoGradGuard no_grad;
  const Forward forward = run(observations, tasks);
  const std::int64_t n = config_.modules, L = config_.module_layers;
  std::vector<ag::Tensor> shares;
  for (std::int64_t l = 0; l + 1 < L; ++l)  // each source module's mean weight over the destinations
    shares.push_back(ag::sum(forward.probabilities[static_cast<std::size_t>(l)], {1}) * (1.0 / static_cast<double>(n)));
  const ag::Tensor& last = forward.probabilities.back();
  shares.push_back(config_.aggregation == "sum" ? last * (1.0 / static_cast<double>(n)) : last);
  return ag::concat(shares, 1) * (1.0 / static_cast<double>(L));
}

double soft_modularization_parameter_count(const PolicyShape& shape, const SoftModularizationConfig& c) {
  const std::int64_t L = c.module_layers, n = c.modules, d = c.module_width, B = c.base_width, G = c.gating_width;
  double count = mlp_parameter_count({shape.observation_size, B, B}) + mlp_parameter_count({shape.num_tasks, B}) +
                 mlp_parameter_count({B, G, G}) + static_cast<double>(L - 1) * mlp_parameter_count({G, n * n});
  for (std::int64_t l = 2; l < L; ++l) count += mlp_parameter_count({n * n * (l - 1), G});
  if (c.aggregation == "softmax") count += mlp_parameter_count({n * n * (L - 1), G}) + mlp_parameter_count({G, n});
  count +=
      static_cast<double>(n) * (mlp_parameter_count({B, d}) + static_cast<double>(L - 1) * mlp_parameter_count({d, d}));
  return count + mlp_parameter_count({d, shape.action_size});
}

namespace {

SoftModularizationConfig soft_modularization_config(const PolicyShape& shape, const MethodOptions& o) {
  SoftModularizationConfig c;
  c.module_layers = option_int(o.own, "module_layers");
  c.modules = option_int(o.own, "modules");
  c.base_width = option_int(o.own, "base_width");
  c.gating_width = option_int(o.own, "gating_width");
  c.aggregation = o.own.at("aggregation").get<std::string>();
  c.init = o.own.at("init").get<std::string>();
  c.module_width = option_int(o.own, "module_width");
  if (c.module_width == 0) {
    // The paper's proportions (base 400 and gating 256 for modules of 256) at MAPS's parameter count.
    const SoftModularizationConfig paper = c;
    auto sized = [&](std::int64_t width) {
      SoftModularizationConfig s = paper;
      s.module_width = width;
      s.base_width = std::max<std::int64_t>(1, std::llround(static_cast<double>(width * paper.base_width) / 256.0));
      s.gating_width = std::max<std::int64_t>(1, std::llround(static_cast<double>(width * paper.gating_width) / 256.0));
      return s;
    };
    c = sized(matched_width(maps_parameter_count(shape, o.maps), [&](std::int64_t width) {
      return soft_modularization_parameter_count(shape, sized(width));
    }));
  }
  return c;
}

}  // namespace

PolicyMethod soft_modularization_method() {
  PolicyMethod method;
  method.name = "soft_modularization";
  method.summary = "Soft Modularization: L layers of n modules, per-layer n x n softmax routing from state and task";
  method.options = {
      io::integer_option("module_layers", 2, 2, 16, "L layers of modules (the paper's MT10 \"Shallow\"; \"Deep\": 4)"),
      io::integer_option("modules", 2, 1, 64, "n modules per layer (Deep: 4)"),
      io::integer_option("module_width", 0, 0, 65536,
                         "each module's width; 0: the paper's proportions (modules 256, base 400, "
                         "gating 256, scaled by one factor from `base_width` and `gating_width`) at "
                         "MAPS's parameter count; the paper: 256 (Deep: 128)"),
      io::integer_option("base_width", 400, 1, 65536,
                         "the base MLP's two layers and the task embedding (at `module_width` 256)"),
      io::integer_option("gating_width", 256, 1, 65536, "the routing network's two layers (at `module_width` 256)"),
      io::choice_option("aggregation", "softmax", {"softmax", "sum", "mean"},
                        "the last layer's sum over modules: `softmax` (the official code's weights), "
                        "`sum` (the paper's Eq. 9, unweighted), `mean` (mtrl's)"),
      io::choice_option("init", "official", {"official", "pytorch"},
                        "the initialisation: `official` (the official code's: routing heads and "
                        "action layer U(+-3e-3), other layers U(+-1/sqrt(output width)) with bias "
                        "0.1), `pytorch` (torch.nn.Linear's)"),
  };
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return soft_modularization_parameter_count(shape, soft_modularization_config(shape, o));
  };
  method.size_keys = "soft_modularization.module_layers, .modules, .module_width, .base_width and .gating_width";
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<SoftModularization>(shape, soft_modularization_config(shape, o), gen);
  };
  return method;
}

}  // namespace maps::core
