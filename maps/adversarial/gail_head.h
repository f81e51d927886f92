#pragma once

#include <cstdint>
#include <vector>

#include "nn/module.h"

// What GAIL's PPO adds to a policy that only gives a mean action: the Gaussian's state-independent log std
// (parameter "log_std" [A]) and the critic V(s, task), a tanh MLP on [s, one_hot(task)] ("critic.layers.i.*";
// orthogonal init as maps/rl's actor-critic: gain sqrt(2) on hidden layers, 1 on the output, zero biases).
namespace maps::adversarial {

class GaussianCriticHead : public nn::Module {
 public:
  GaussianCriticHead(std::int64_t observation_size, std::int64_t action_size, std::int64_t num_tasks,
                     const std::vector<std::int64_t>& critic_hidden, double initial_log_std, ag::Generator& gen);

  // Values [n] of standardised observations [n, S] under their tasks.
  ag::Tensor value(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks);
  const ag::Tensor& log_std() const { return parameter_at(log_std_); }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<GaussianCriticHead>(*this); }

 private:
  std::int64_t num_tasks_;
  std::size_t log_std_ = 0;
  std::size_t critic_ = 0;
};

}  // namespace maps::adversarial
