#include "maps/policies/top_k_moe.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy_registry.h"
#include "nn/mlp.h"
#include "nn/module_list.h"

namespace maps::core {
namespace {

// The squared coefficient of variation of a [E] vector, var / (mean^2 + 1e-10) with the unbiased variance (the
// reference port's); 0 for a single expert.
ag::Tensor cv_squared(const ag::Tensor& v) {
  const std::int64_t E = v.size(0);
  if (E < 2) return ag::mul(ag::sum(v), 0.0);
  const ag::Tensor mean = ag::mean(v);
  const ag::Tensor variance = ag::sum(ag::square(v - mean)) * (1.0 / static_cast<double>(E - 1));
  return variance / (ag::square(mean) + 1e-10);
}

}  // namespace

TopKMoE::TopKMoE(PolicyShape shape, const TopKMoEConfig& config, ag::Generator& gen)
    : Policy("TopKMoE", shape), config_(config) {
  detail::check_construction("TopKMoE", shape, {config.width}, /*need_hidden=*/true);
  if (config.experts < 2 || config.layers < 1 || config.top_k < 2 || config.top_k > config.experts)
    throw std::invalid_argument("TopKMoE: expected experts >= 2, layers >= 1 and 2 <= top_k <= experts, got " +
                                std::to_string(config.experts) + ", " + std::to_string(config.layers) + " and " +
                                std::to_string(config.top_k) + " (top_k_moe.top_k <= top_k_moe.experts)");
  const std::int64_t in = shape.observation_size + shape.num_tasks;
  auto experts = std::make_shared<nn::ModuleList>();
  for (std::int64_t i = 0; i < config.experts; ++i)
    experts->push_back(std::make_shared<nn::MLP>(
        detail::layer_sizes(in, std::vector<std::int64_t>(config.layers, config.width), shape.action_size),
        nn::Activation::ReLU, gen));
  experts_ = register_module("experts", experts);
  gate_weight_ = register_parameter("gate_weight", ag::zeros({in, config.experts}, ag::Dtype::Float32));
  noise_weight_ = register_parameter("noise_weight", ag::zeros({in, config.experts}, ag::Dtype::Float32));
}

ag::Tensor TopKMoE::gate_noise(std::int64_t rows, std::int64_t experts, std::uint64_t noise_seed, ag::Dtype dtype) {
  ag::Generator gen(noise_seed ^ 0x6761746eULL);  // "gatn"
  return ag::randn({rows, experts}, gen, dtype);
}

TopKMoE::Gate TopKMoE::gate(const ag::Tensor& inputs, const std::uint64_t* noise_seed) {
  const std::int64_t n = inputs.size(0), E = config_.experts, k = config_.top_k;
  const ag::Tensor clean = ag::matmul(inputs, parameter_at(gate_weight_));  // [n, E]
  const bool noisy = noise_seed != nullptr && config_.noise;
  ag::Tensor sigma, logits = clean;
  if (noisy) {
    sigma = ag::softplus(ag::matmul(inputs, parameter_at(noise_weight_))) + 0.01;
    logits = clean + gate_noise(n, E, *noise_seed, clean.dtype()) * sigma;
  }
  // Each row's experts by logit, best first (ties to the lower index: a stable sort).
  const std::vector<double> values = logits.to_vector();
  std::vector<std::int64_t> order(static_cast<std::size_t>(n * E));
  Gate g;
  g.chosen.reserve(static_cast<std::size_t>(n * k));
  std::vector<double> mask(static_cast<std::size_t>(n * E), -1e9);
  for (std::int64_t r = 0; r < n; ++r) {
    auto row = order.begin() + r * E;
    std::iota(row, row + E, std::int64_t{0});
    std::stable_sort(row, row + E, [&](std::int64_t a, std::int64_t b) {
      return values[static_cast<std::size_t>(r * E + a)] > values[static_cast<std::size_t>(r * E + b)];
    });
    for (std::int64_t j = 0; j < k; ++j) {
      g.chosen.push_back(row[j]);
      mask[static_cast<std::size_t>(r * E + row[j])] = 0.0;
    }
  }
  g.gates = ag::softmax(logits + ag::from_vector(mask, {n, E}, logits.dtype()), 1);
  if (noisy && k < E) {
    // P(x, i): the chance that expert i's clean logit plus fresh noise beats the threshold it must pass to be (or
    // stay) in the top k: the (k+1)-th largest noisy logit for a chosen expert, the k-th for the others.
    std::vector<std::int64_t> threshold_at(static_cast<std::size_t>(n * E));
    for (std::int64_t r = 0; r < n; ++r) {
      const auto row = order.begin() + r * E;
      for (std::int64_t i = 0; i < E; ++i) {
        const bool in_top = mask[static_cast<std::size_t>(r * E + i)] == 0.0;
        threshold_at[static_cast<std::size_t>(r * E + i)] = r * E + row[in_top ? k : k - 1];
      }
    }
    const ag::Tensor threshold = ag::reshape(ag::index_select(ag::reshape(logits, {n * E, 1}), threshold_at), {n, E});
    const ag::Tensor z = (clean - threshold) / sigma * (1.0 / std::sqrt(2.0));
    g.load = ag::sum((ag::erf(z) + 1.0) * 0.5, {0});
  }
  return g;
}

ag::Tensor gated_expert_sum(const nn::ModuleList& experts, const ag::Tensor& inputs,
                            const std::vector<std::int64_t>& chosen, const ag::Tensor& gates, std::int64_t k) {
  const std::int64_t n = inputs.size(0), E = gates.size(1);
  const ag::Tensor flat_gates = ag::reshape(gates, {n * E, 1});
  ag::Tensor out;
  for (std::int64_t i = 0; i < E; ++i) {
    std::vector<std::int64_t> rows, gate_at;
    for (std::int64_t r = 0; r < n; ++r)
      for (std::int64_t j = 0; j < k; ++j)
        if (chosen[static_cast<std::size_t>(r * k + j)] == i) {
          rows.push_back(r);
          gate_at.push_back(r * E + i);
        }
    if (rows.empty()) continue;
    const ag::Tensor values = experts.at<nn::MLP>(static_cast<std::size_t>(i)).forward(ag::index_select(inputs, rows));
    const ag::Tensor part = ag::index_add(values * ag::index_select(flat_gates, gate_at), rows, n);
    out = out.defined() ? out + part : part;
  }
  return out;
}

ag::Tensor TopKMoE::mixture(const ag::Tensor& inputs, const Gate& g) {
  return gated_expert_sum(child_at<nn::ModuleList>(experts_), inputs, g.chosen, g.gates, config_.top_k);
}

ag::Tensor TopKMoE::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("TopKMoE::act", shape(), observations, tasks);
  if (observations.size(0) == 0) return ag::zeros({0, shape().action_size}, observations.dtype());
  const ag::Tensor inputs = detail::with_task_one_hot(observations, tasks, shape().num_tasks);
  return mixture(inputs, gate(inputs, nullptr));
}

LossTerms TopKMoE::loss(const Batch& batch) {
  detail::check_batch("TopKMoE::loss", shape(), batch);
  const ag::Tensor inputs = detail::with_task_one_hot(batch.observations, batch.tasks, shape().num_tasks);
  const Gate g = gate(inputs, &batch.noise_seed);
  const ag::Tensor bc = bc_loss(mixture(inputs, g), batch);
  const ag::Tensor importance = cv_squared(ag::sum(g.gates, {0}));
  const ag::Tensor load = g.load.defined() ? cv_squared(g.load) : ag::mul(importance, 0.0);
  return LossTerms{bc + (importance + load) * config_.balance,
                   {{"bc", bc}, {"importance", importance}, {"load", load}}};
}

PolicyForward TopKMoE::forward_terms(const Batch& batch) {
  detail::check_batch("TopKMoE::forward_terms", shape(), batch);
  const ag::Tensor inputs = detail::with_task_one_hot(batch.observations, batch.tasks, shape().num_tasks);
  const Gate clean = gate(inputs, nullptr);
  const ag::Tensor importance = cv_squared(ag::sum(clean.gates, {0}));
  const Gate noisy = gate(inputs, &batch.noise_seed);
  const ag::Tensor load = noisy.load.defined() ? cv_squared(noisy.load) : ag::mul(importance, 0.0);
  PolicyForward result;
  result.mean_actions = mixture(inputs, clean);
  result.regularizer = LossTerms{(importance + load) * config_.balance, {{"importance", importance}, {"load", load}}};
  return result;
}

ag::Tensor TopKMoE::routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("TopKMoE::routing", shape(), observations, tasks);
  ag::NoGradGuard no_grad;
  return gate(detail::with_task_one_hot(observations, tasks, shape().num_tasks), nullptr).gates;
}

double top_k_moe_parameter_count(const PolicyShape& shape, const TopKMoEConfig& c) {
  const std::int64_t in = shape.observation_size + shape.num_tasks;
  return static_cast<double>(c.experts) * mlp_parameter_count(detail::layer_sizes(
                                              in, std::vector<std::int64_t>(c.layers, c.width), shape.action_size)) +
         2.0 * static_cast<double>(in * c.experts);
}

namespace {

TopKMoEConfig top_k_moe_config(const PolicyShape& shape, const MethodOptions& o) {
  TopKMoEConfig c;
  c.experts = option_int(o.own, "experts");
  c.top_k = option_int(o.own, "top_k");
  c.layers = option_int(o.own, "layers");
  c.balance = o.own.at("balance").get<double>();
  c.noise = o.own.at("noise").get<bool>();
  c.width = option_int(o.own, "width");
  return with_matched_width(c, &TopKMoEConfig::width, shape, o, top_k_moe_parameter_count);
}

}  // namespace

PolicyMethod top_k_moe_method() {
  PolicyMethod method;
  method.name = "top_k_moe";
  method.summary =
      "Sparsely-gated MoE: noisy top-k gating on [state, task] over expert MLPs, importance and load losses";
  method.options = {
      io::integer_option("experts", 4, 2, 64, "expert MLPs on [state, one-hot task]"),
      io::integer_option(
          "top_k", 2, 2, 64,
          "experts each row runs (the others do not run for it); at least 2: one chosen expert has softmax "
          "weight 1 whatever its logit, and the gate would learn nothing from the BC loss"),
      io::integer_option("layers", 3, 1, 64, "hidden layers per expert (ReLU)"),
      io::integer_option("width", 0, 0, 65536, "expert width; 0: matched to MAPS's parameter count"),
      io::number_option("balance", 0.01, 0.0, 1e6,
                        "weight of the importance and load losses (CV^2 each; Shazeer et al.'s "
                        "reference port's value; 0: none)"),
      io::boolean_option("noise", true,
                         "noisy gating in training (eps * softplus(x W_noise)); without noise the "
                         "load loss is not defined and is 0"),
  };
  method.check = [](const nlohmann::json& own) {
    if (option_int(own, "top_k") > option_int(own, "experts"))
      throw std::invalid_argument("config top_k_moe.top_k: expected at most top_k_moe.experts (" +
                                  own.at("experts").dump() + "), got " + own.at("top_k").dump());
  };
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return top_k_moe_parameter_count(shape, top_k_moe_config(shape, o));
  };
  method.size_keys = "top_k_moe.experts, top_k_moe.layers and top_k_moe.width";
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<TopKMoE>(shape, top_k_moe_config(shape, o), gen);
  };
  return method;
}

}  // namespace maps::core
