#include "maps/adversarial/gail_config.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "autograd/parallel.h"

namespace maps::adversarial {
namespace {

void require(bool ok, const std::string& key, const std::string& expected, const std::string& got) {
  if (!ok) throw std::invalid_argument("config gail." + key + ": expected " + expected + ", got " + got);
}

void check_real(double value, const std::string& key, double low, double high, bool low_open = false) {
  const bool ok = std::isfinite(value) && (low_open ? value > low : value >= low) && value <= high;
  require(
      ok, key,
      std::string("a number in ") + (low_open ? "(" : "[") + std::to_string(low) + ", " + std::to_string(high) + "]",
      std::to_string(value));
}

void check_whole(std::int64_t value, const std::string& key, std::int64_t low, std::int64_t high) {
  require(value >= low && value <= high, key,
          "a whole number in [" + std::to_string(low) + ", " + std::to_string(high) + "]", std::to_string(value));
}

}  // namespace

void check_gail_config(const GailConfig& c) {
  check_whole(c.env_steps_per_task, "env_steps_per_task", 1, 10'000'000'000LL);
  check_whole(c.rollout_episodes, "rollout_episodes", 1, 1000);
  check_whole(c.threads, "threads", 1, ag::kMaxThreads);
  check_whole(c.epochs, "epochs", 1, 1000);
  check_whole(c.minibatch_per_task, "minibatch_per_task", 1, 1'000'000);
  check_real(c.clip, "clip", 0.0, 1.0, true);
  check_real(c.gamma, "gamma", 0.0, 1.0);
  check_real(c.gae_lambda, "gae_lambda", 0.0, 1.0);
  check_real(c.learning_rate, "learning_rate", 0.0, 1.0, true);
  check_real(c.adam_eps, "adam_eps", 0.0, 1.0, true);
  check_real(c.value_coef, "value_coef", 0.0, 1e3);
  check_real(c.entropy_coef, "entropy_coef", 0.0, 1.0);
  check_real(c.max_grad_norm, "max_grad_norm", 0.0, 1e6, true);
  require(!c.critic_hidden.empty() && c.critic_hidden.size() <= 8, "critic_hidden", "1 to 8 layer sizes",
          std::to_string(c.critic_hidden.size()) + " sizes");
  for (const std::int64_t size : c.critic_hidden) check_whole(size, "critic_hidden", 1, 4096);
  check_real(c.initial_log_std, "initial_log_std", -10.0, 2.0);
  const auto& kinds = gail_reward_kinds();
  require(std::find(kinds.begin(), kinds.end(), c.reward) != kinds.end(), "reward", "\"gail\", \"log_d\" or \"logit\"",
          "\"" + c.reward + "\"");
  check_discriminator_config(c.discriminator);
  check_discriminator_loss_config(c.discriminator_loss);
  check_real(c.discriminator_learning_rate, "discriminator_learning_rate", 0.0, 1.0, true);
  check_whole(c.discriminator_updates, "discriminator_updates", 0, 100'000);
  check_whole(c.discriminator_batch_per_task, "discriminator_batch_per_task", 1, 1'000'000);
  check_whole(c.discriminator_warmup_iterations, "discriminator_warmup_iterations", 0, 1'000'000);
  check_whole(c.discriminator_warmup_updates, "discriminator_warmup_updates", 0, 100'000);
  check_real(c.bc_weight, "bc_weight", 0.0, 1e6);
  check_whole(c.bc_states_per_task, "bc_states_per_task", 1, 1'000'000);
  require(c.checkpoint == "last" || c.checkpoint == "validation", "checkpoint", "\"last\" or \"validation\"",
          "\"" + c.checkpoint + "\"");
  check_whole(c.checkpoint_every, "checkpoint_every", 1, 1'000'000);
  // 0: every validation state (the run config's train.validation_states_per_task, whose range this is).
  check_whole(c.validation_states_per_task, "validation_states_per_task", 0, 100'000'000);
}

}  // namespace maps::adversarial
