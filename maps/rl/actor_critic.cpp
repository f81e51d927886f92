#include "maps/rl/actor_critic.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace maps::rl {
namespace {

std::vector<std::int64_t> layer_sizes(std::int64_t in, const std::vector<std::int64_t>& hidden, std::int64_t out) {
  std::vector<std::int64_t> sizes{in};
  sizes.insert(sizes.end(), hidden.begin(), hidden.end());
  sizes.push_back(out);
  return sizes;
}

// Orthogonal weights (gain sqrt(2) on hidden layers, `output_gain` on the last) and zero biases.
void init_orthogonal(nn::MLP& mlp, double output_gain, ag::Generator& gen) {
  for (std::size_t i = 0; i < mlp.num_layers(); ++i) {
    const std::string prefix = "layers." + std::to_string(i) + ".";
    ag::Tensor weight = mlp.parameter(prefix + "weight");
    ag::Tensor bias = mlp.parameter(prefix + "bias");
    nn::init::orthogonal_(weight, i + 1 == mlp.num_layers() ? output_gain : std::sqrt(2.0), gen);
    nn::init::zeros_(bias);
  }
}

}  // namespace

ag::Tensor gaussian_log_prob(const ag::Tensor& mean, const ag::Tensor& log_std, const ag::Tensor& actions) {
  if (mean.dim() != 2 || actions.shape() != mean.shape() || log_std.dim() != 1 || log_std.size(0) != mean.size(1))
    throw std::invalid_argument("gaussian_log_prob: expected mean and actions [B, D] and log_std [D], got mean " +
                                ag::to_string(mean.shape()) + ", log_std " + ag::to_string(log_std.shape()) +
                                ", actions " + ag::to_string(actions.shape()));
  const ag::Tensor z = (actions - mean) * ag::exp(-log_std);
  const double constant = 0.5 * std::log(2.0 * M_PI) * static_cast<double>(mean.size(1));
  return ag::sum(ag::square(z) * -0.5, {1}) - ag::sum(log_std) - constant;
}

ag::Tensor gaussian_entropy(const ag::Tensor& log_std) {
  const double per_dim = 0.5 * (1.0 + std::log(2.0 * M_PI));
  return ag::sum(log_std) + per_dim * static_cast<double>(log_std.numel());
}

ag::Tensor ppo_clip_loss(const ag::Tensor& log_prob, const ag::Tensor& old_log_prob, const ag::Tensor& advantages,
                         double clip) {
  const ag::Tensor ratio = ag::exp(log_prob - old_log_prob);
  const ag::Tensor unclipped = ratio * advantages;
  const ag::Tensor clipped = ag::clamp(ratio, 1.0 - clip, 1.0 + clip) * advantages;
  return -ag::mean(ag::minimum(unclipped, clipped));
}

ActorCritic::ActorCritic(const ActorCriticConfig& config, ag::Generator& gen) : Module("ActorCritic"), config_(config) {
  if (config.observation_size <= 0 || config.action_size <= 0)
    throw std::invalid_argument("ActorCritic: observation and action sizes must be positive, got " +
                                std::to_string(config.observation_size) + " and " + std::to_string(config.action_size));
  auto policy = std::make_shared<nn::MLP>(layer_sizes(config.observation_size, config.hidden, config.action_size),
                                          nn::Activation::Tanh, gen);
  auto value =
      std::make_shared<nn::MLP>(layer_sizes(config.observation_size, config.hidden, 1), nn::Activation::Tanh, gen);
  init_orthogonal(*policy, 0.01, gen);
  init_orthogonal(*value, 1.0, gen);
  policy_ = register_module("policy", policy);
  log_std_ = register_parameter("log_std", ag::full({config.action_size}, config.initial_log_std));
  value_ = register_module("value", value);
}

ag::Tensor ActorCritic::value(const ag::Tensor& obs) {
  const ag::Tensor v = value_net().forward(obs);
  return ag::reshape(v, {v.size(0)});
}

}  // namespace maps::rl
