#include "maps/adversarial/gail_head.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "nn/init.h"
#include "nn/mlp.h"

namespace maps::adversarial {

GaussianCriticHead::GaussianCriticHead(std::int64_t observation_size, std::int64_t action_size, std::int64_t num_tasks,
                                       const std::vector<std::int64_t>& critic_hidden, double initial_log_std,
                                       ag::Generator& gen)
    : Module("GaussianCriticHead"), num_tasks_(num_tasks) {
  if (observation_size < 1 || action_size < 1 || num_tasks < 1)
    throw std::invalid_argument("GaussianCriticHead: observation, action and task counts must be positive");
  std::vector<std::int64_t> sizes{observation_size + num_tasks};
  sizes.insert(sizes.end(), critic_hidden.begin(), critic_hidden.end());
  sizes.push_back(1);
  auto critic = std::make_shared<nn::MLP>(sizes, nn::Activation::Tanh, gen);
  for (std::size_t i = 0; i < critic->num_layers(); ++i) {
    const std::string prefix = "layers." + std::to_string(i) + ".";
    ag::Tensor weight = critic->parameter(prefix + "weight");
    ag::Tensor bias = critic->parameter(prefix + "bias");
    nn::init::orthogonal_(weight, i + 1 == critic->num_layers() ? 1.0 : std::sqrt(2.0), gen);
    nn::init::zeros_(bias);
  }
  log_std_ = register_parameter("log_std", ag::full({action_size}, initial_log_std));
  critic_ = register_module("critic", critic);
}

ag::Tensor GaussianCriticHead::value(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
  const ag::Tensor inputs = ag::concat({observations, ag::one_hot(tasks, num_tasks_, observations.dtype())}, 1);
  const ag::Tensor v = child_at<nn::MLP>(critic_).forward(inputs);
  return ag::reshape(v, {v.size(0)});
}

}  // namespace maps::adversarial
