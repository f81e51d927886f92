#include "maps/policies/care.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy_registry.h"
#include "nn/mlp.h"
#include "nn/module_list.h"
#include "nn/parallel_linear.h"

namespace maps::core {

CARE::CARE(PolicyShape shape, const CAREConfig& config, ag::Generator& gen) : Policy("CARE", shape), config_(config) {
  detail::check_construction("CARE", shape, {config.width, config.encoder_width, config.context_width}, true);
  if (config.encoders < 1 || config.layers < 1)
    throw std::invalid_argument("CARE: encoders and layers must be >= 1, got " + std::to_string(config.encoders) +
                                " and " + std::to_string(config.layers));
  if (config.attention != "dot" && config.attention != "task")
    throw std::invalid_argument("CARE: attention must be \"dot\" or \"task\", got \"" + config.attention + "\"");
  if (config.attention == "dot" && config.encoder_width != config.context_width)
    throw std::invalid_argument("CARE: \"dot\" attention needs care.encoder_width = care.context_width, got " +
                                std::to_string(config.encoder_width) + " and " + std::to_string(config.context_width));
  const std::int64_t C = config.context_width, E = config.encoder_width;
  embedding_ = register_parameter("task_embedding", ag::randn({shape.num_tasks, C}, gen, ag::Dtype::Float32));
  context_ = register_module("context",
                             std::make_shared<nn::MLP>(std::vector<std::int64_t>{C, C, C}, nn::Activation::ReLU, gen));
  auto encoders = std::make_shared<nn::ModuleList>();
  encoders->push_back(std::make_shared<nn::ParallelLinear>(config.encoders, shape.observation_size, E, gen));
  encoders->push_back(std::make_shared<nn::ParallelLinear>(config.encoders, E, E, gen));
  encoders_ = register_module("encoders", encoders);
  if (config.attention == "task")
    attention_ = register_module(
        "attention",
        std::make_shared<nn::MLP>(std::vector<std::int64_t>{C, C, config.encoders}, nn::Activation::ReLU, gen));
  actor_ = register_module(
      "actor",
      std::make_shared<nn::MLP>(
          detail::layer_sizes(C + E, std::vector<std::int64_t>(config.layers, config.width), shape.action_size),
          nn::Activation::ReLU, gen));
}

CARE::Forward CARE::run(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  const auto n = static_cast<std::int64_t>(tasks.size());
  const ag::Tensor embedded = ag::index_select(parameter_at(embedding_), tasks);  // [n, C]
  const ag::Tensor context = child_at<nn::MLP>(context_).forward(embedded);       // [n, C]
  const auto& encoders = child_at<nn::ModuleList>(encoders_);
  const ag::Tensor encoded = encoders.at<nn::ParallelLinear>(1).forward(
      ag::relu(encoders.at<nn::ParallelLinear>(0).forward(observations)));  // [k, n, E]
  ag::Tensor logits;
  if (config_.attention == "dot") {
    // <E_j(s), z> with the context's gradient stopped, as CARE's Alg. 1 writes it.
    logits = ag::transpose(ag::sum(ag::mul(encoded, context.detach()), {2}), 0, 1);  // [n, k]
  } else {
    logits = ag::mul(child_at<nn::MLP>(attention_).forward(embedded), 1.0 / config_.temperature);
  }
  const ag::Tensor attention = ag::softmax(logits, 1);  // [n, k]
  const ag::Tensor weights = ag::reshape(ag::transpose(attention, 0, 1), {config_.encoders, n, 1});
  const ag::Tensor mixed = ag::sum(ag::mul(encoded, weights), {0});  // [n, E]
  return {child_at<nn::MLP>(actor_).forward(ag::concat({context, mixed}, 1)), attention};
}

ag::Tensor CARE::act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("CARE::act", shape(), observations, tasks);
  return run(observations, tasks).actions;
}

LossTerms CARE::loss(const Batch& batch) {
  detail::check_batch("CARE::loss", shape(), batch);
  return detail::bc_terms(bc_loss(run(batch.observations, batch.tasks).actions, batch));
}

ag::Tensor CARE::routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  detail::check_observations("CARE::routing", shape(), observations, tasks);
  ag::NoGradGuard no_grad;
  return run(observations, tasks).attention;
}

double care_parameter_count(const PolicyShape& shape, const CAREConfig& c) {
  const double K = static_cast<double>(shape.num_tasks), k = static_cast<double>(c.encoders);
  const std::int64_t C = c.context_width, E = c.encoder_width;
  double count =
      K * static_cast<double>(C) + mlp_parameter_count({C, C, C}) +
      k * mlp_parameter_count({shape.observation_size, E, E}) +
      mlp_parameter_count(detail::layer_sizes(C + E, std::vector<std::int64_t>(c.layers, c.width), shape.action_size));
  if (c.attention == "task") count += mlp_parameter_count({C, C, c.encoders});
  return count;
}

namespace {

CAREConfig care_config(const PolicyShape& shape, const MethodOptions& o) {
  CAREConfig c;
  c.encoders = option_int(o.own, "encoders");
  c.encoder_width = option_int(o.own, "encoder_width");
  c.context_width = option_int(o.own, "context_width");
  c.layers = option_int(o.own, "layers");
  c.attention = o.own.at("attention").get<std::string>();
  c.temperature = o.own.at("temperature").get<double>();
  c.width = option_int(o.own, "width");
  return with_matched_width(c, &CAREConfig::width, shape, o, care_parameter_count);
}

}  // namespace

PolicyMethod care_method() {
  PolicyMethod method;
  method.name = "care";
  method.summary =
      "CARE-style: k state encoders mixed by attention from a learned task embedding, an actor on [context, mixture]";
  method.options = {
      io::integer_option("encoders", 6, 1, 4096, "k state encoders (CARE's MT10 setting)"),
      io::integer_option("encoder_width", 50, 1, 4096, "each encoder: S -> 50 -> 50 (ReLU between)"),
      io::integer_option("context_width", 50, 1, 4096,
                         "the learned task embedding and the context MLP's two layers (CARE: 2 x 50 "
                         "over a frozen language-model embedding)"),
      io::integer_option("layers", 3, 1, 4096, "the actor's hidden layers on [context, mixed encoding]"),
      io::integer_option("width", 0, 0, 65536, "the actor's width; 0: matched to MAPS's parameter count (CARE: 400)"),
      io::choice_option("attention", "dot", {"dot", "task"},
                        "`dot`: softmax_j <E_j(s), stopgrad(context)> (CARE's paper: state and "
                        "task); `task`: softmax(MLP(embedding) / temperature) (its public code: the "
                        "task alone)"),
      io::number_option("temperature", 1.0, 1e-3, 1e3,
                        "the `task` attention's softmax temperature, in [0.001, 1000] (refused with "
                        "`dot`, which has none)"),
  };
  method.check = [](const nlohmann::json& own) {
    const std::string attention = own.at("attention").get<std::string>();
    if (attention == "dot" && option_int(own, "encoder_width") != option_int(own, "context_width"))
      throw std::invalid_argument(
          "config care.encoder_width: \"dot\" attention compares encodings with the context, so it must equal "
          "care.context_width");
    const double temperature = own.at("temperature").get<double>();
    if (attention == "dot" && temperature != 1.0)
      throw std::invalid_argument(
          "config care.temperature: only the \"task\" attention has a temperature (\"dot\" is CARE's paper's "
          "softmax of dot products), so " +
          own.at("temperature").dump() + " would do nothing; set care.attention \"task\" or leave it out");
  };
  method.parameters = [](const PolicyShape& shape, const MethodOptions& o) {
    return care_parameter_count(shape, care_config(shape, o));
  };
  method.size_keys = "care.encoders, care.encoder_width, care.context_width, care.layers and care.width";
  method.make = [](const PolicyShape& shape, const MethodOptions& o, ag::Generator& gen) -> std::shared_ptr<Policy> {
    return std::make_shared<CARE>(shape, care_config(shape, o), gen);
  };
  return method;
}

}  // namespace maps::core
