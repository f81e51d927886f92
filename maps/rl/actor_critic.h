#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "nn/nn.h"

// The Gaussian MLP actor-critic that PPO trains into an expert.
namespace maps::rl {

// log N(actions; mean, exp(log_std)^2 I) summed over the last dim: mean and actions [B, D], log_std [D] -> [B].
// Written with ag ops, so it is differentiable in mean and log_std (and works in float64 for gradcheck).
ag::Tensor gaussian_log_prob(const ag::Tensor& mean, const ag::Tensor& log_std, const ag::Tensor& actions);
// Entropy of the diagonal Gaussian, sum_d (log_std_d + 0.5 log(2 pi e)) -> shape {}.
ag::Tensor gaussian_entropy(const ag::Tensor& log_std);

// PPO's clipped surrogate, to be minimised: -mean(min(r A, clip(r, 1 - eps, 1 + eps) A)) with
// r = exp(log_prob - old_log_prob). All inputs [B]; advantages and old_log_prob are constants.
ag::Tensor ppo_clip_loss(const ag::Tensor& log_prob, const ag::Tensor& old_log_prob, const ag::Tensor& advantages,
                         double clip);

struct ActorCriticConfig {
  std::int64_t observation_size = 0;
  std::int64_t action_size = 0;
  std::vector<std::int64_t> hidden = {64, 64};
  double initial_log_std = 0.0;
};

// Policy: tanh MLP obs-h1-...-act giving the mean, with a state-independent log-std parameter. Value: tanh MLP
// obs-h1-...-1. Orthogonal init as the common PPO recipe: gain sqrt(2) on hidden layers, 0.01 on the policy
// output, 1 on the value output, zero biases. Parameter names: "policy.layers.i.weight", "policy.layers.i.bias",
// "log_std", "value.layers.i.weight", ... Float32 by default (to(Float64) for gradient checks).
class ActorCritic : public nn::Module {
 public:
  ActorCritic(const ActorCriticConfig& config, ag::Generator& gen);

  // Normalised observations [B, obs] -> mean actions [B, act].
  ag::Tensor mean_action(const ag::Tensor& obs) { return policy().forward(obs); }
  // [B, obs] -> [B] (the value MLP's single output, reshaped).
  ag::Tensor value(const ag::Tensor& obs);
  const ag::Tensor& log_std() const { return parameter_at(log_std_); }

  nn::MLP& policy() const { return child_at<nn::MLP>(policy_); }
  nn::MLP& value_net() const { return child_at<nn::MLP>(value_); }
  const ActorCriticConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ActorCritic>(*this); }

 private:
  ActorCriticConfig config_;
  std::size_t policy_ = 0;
  std::size_t log_std_ = 0;
  std::size_t value_ = 0;
};

}  // namespace maps::rl
