#include "maps/adversarial/discriminator.h"

#include <stdexcept>
#include <string>

#include "nn/mlp.h"

namespace maps::adversarial {

void check_discriminator_config(const DiscriminatorConfig& config) {
  if (config.hidden.empty() || config.hidden.size() > 8)
    throw std::invalid_argument("config gail.discriminator_hidden: expected 1 to 8 layer sizes, got " +
                                std::to_string(config.hidden.size()));
  for (const std::int64_t size : config.hidden)
    if (size < 1 || size > 4096)
      throw std::invalid_argument("config gail.discriminator_hidden: every size must be in [1, 4096], got " +
                                  std::to_string(size));
  if (config.activation != "tanh" && config.activation != "relu")
    throw std::invalid_argument("config gail.discriminator_activation: expected \"tanh\" or \"relu\", got \"" +
                                config.activation + "\"");
  if (config.conditioning != "input" && config.conditioning != "heads")
    throw std::invalid_argument("config gail.discriminator_conditioning: expected \"input\" or \"heads\", got \"" +
                                config.conditioning + "\"");
}

Discriminator::Discriminator(const DiscriminatorConfig& config, std::int64_t observation_size, std::int64_t action_size,
                             std::int64_t num_tasks, ag::Generator& gen)
    : Module("Discriminator"),
      config_(config),
      observation_size_(observation_size),
      action_size_(action_size),
      num_tasks_(num_tasks) {
  check_discriminator_config(config);
  if (observation_size < 1 || action_size < 1 || num_tasks < 1)
    throw std::invalid_argument("Discriminator: observation, action and task counts must be positive, got " +
                                std::to_string(observation_size) + ", " + std::to_string(action_size) + " and " +
                                std::to_string(num_tasks));
  const bool heads = config.conditioning == "heads";
  std::vector<std::int64_t> sizes{observation_size + action_size + (heads ? 0 : num_tasks)};
  sizes.insert(sizes.end(), config.hidden.begin(), config.hidden.end());
  sizes.push_back(heads ? num_tasks : 1);
  mlp_ = register_module("mlp", std::make_shared<nn::MLP>(sizes, config.activation, gen));
}

ag::Tensor Discriminator::logits(const ag::Tensor& observations, const ag::Tensor& actions,
                                 const std::vector<std::int64_t>& tasks) {
  if (observations.dim() != 2 || observations.size(1) != observation_size_ || actions.dim() != 2 ||
      actions.size(1) != action_size_ || actions.size(0) != observations.size(0))
    throw std::invalid_argument("Discriminator::logits: expected observations [n, " +
                                std::to_string(observation_size_) + "] and actions [n, " +
                                std::to_string(action_size_) + "], got " + ag::to_string(observations.shape()) +
                                " and " + ag::to_string(actions.shape()));
  return logits_of_pairs(ag::concat({observations, actions}, 1), tasks);
}

ag::Tensor Discriminator::logits_of_pairs(const ag::Tensor& pairs, const std::vector<std::int64_t>& tasks) {
  const std::int64_t width = observation_size_ + action_size_;
  if (pairs.dim() != 2 || pairs.size(1) != width || pairs.size(0) != static_cast<std::int64_t>(tasks.size()))
    throw std::invalid_argument("Discriminator: expected pairs [n, " + std::to_string(width) +
                                "] and n task ids, got " + ag::to_string(pairs.shape()) + " and " +
                                std::to_string(tasks.size()) + " ids");
  for (const std::int64_t task : tasks)
    if (task < 0 || task >= num_tasks_)
      throw std::invalid_argument("Discriminator: task id " + std::to_string(task) + " is outside [0, " +
                                  std::to_string(num_tasks_) + ")");
  const std::int64_t n = pairs.size(0);
  const ag::Tensor one_hot = ag::one_hot(tasks, num_tasks_, pairs.dtype());
  auto& mlp = child_at<nn::MLP>(mlp_);
  if (config_.conditioning == "heads") return ag::reshape(ag::sum(mlp.forward(pairs) * one_hot, {1}), {n});
  return ag::reshape(mlp.forward(ag::concat({pairs, one_hot}, 1)), {n});
}

}  // namespace maps::adversarial
