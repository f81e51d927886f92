#pragma once

namespace maps::rl {

// The update's recipe, shared by expert training (PPOConfig) and GAIL's generator (adversarial::GailConfig).
struct PPOUpdateConfig {
  int epochs = 10;
  double gamma = 0.99;
  double gae_lambda = 0.95;
  double clip = 0.2;
  double learning_rate = 3e-4;
  double adam_eps = 1e-5;
  bool anneal_learning_rate = true;
  double value_coef = 0.5;
  double entropy_coef = 0.0;
  double max_grad_norm = 0.5;
};

}  // namespace maps::rl
