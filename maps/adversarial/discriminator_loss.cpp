#include "maps/adversarial/discriminator_loss.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace maps::adversarial {
namespace {

// Share of entries of `logits` above 0 (positive) or below 0.
double share_of_sign(const ag::Tensor& logits, bool positive) {
  const auto values = ag::to_eigen_double(logits.detach());
  const auto n = static_cast<double>(values.size());
  const auto hits = positive ? (values.array() > 0.0).count() : (values.array() < 0.0).count();
  return n > 0 ? static_cast<double>(hits) / n : 0.0;
}

// Bernoulli entropy of sigmoid(l): p softplus(-l) + (1 - p) softplus(l), with p = sigmoid(l).
ag::Tensor bernoulli_entropy(const ag::Tensor& logits) {
  const ag::Tensor p = ag::sigmoid(logits);
  return p * ag::softplus(-logits) + (1.0 - p) * ag::softplus(logits);
}

}  // namespace

void check_discriminator_loss_config(const DiscriminatorLossConfig& config) {
  if (!std::isfinite(config.gradient_penalty) || config.gradient_penalty < 0.0 || config.gradient_penalty > 1e4)
    throw std::invalid_argument("config gail.gradient_penalty: expected a weight in [0, 1e4], got " +
                                std::to_string(config.gradient_penalty));
  if (!std::isfinite(config.entropy_bonus) || config.entropy_bonus < 0.0 || config.entropy_bonus > 1.0)
    throw std::invalid_argument("config gail.entropy_bonus: expected a weight in [0, 1], got " +
                                std::to_string(config.entropy_bonus));
}

DiscriminatorLoss discriminator_loss(Discriminator& discriminator, const ag::Tensor& expert_pairs,
                                     const ag::Tensor& policy_pairs, const std::vector<std::int64_t>& tasks,
                                     const DiscriminatorLossConfig& config, const ag::Tensor& mix) {
  const auto n = static_cast<std::int64_t>(tasks.size());
  if (expert_pairs.shape() != policy_pairs.shape() || expert_pairs.dim() != 2 || expert_pairs.size(0) != n || n == 0)
    throw std::invalid_argument(
        "discriminator_loss: expected demonstration and policy pairs of one shape [n, S + A] "
        "with n = " +
        std::to_string(n) + " task ids (n > 0), got " + ag::to_string(expert_pairs.shape()) + " and " +
        ag::to_string(policy_pairs.shape()));
  if (mix.dim() != 1 || mix.size(0) != n)
    throw std::invalid_argument("discriminator_loss: expected mix [" + std::to_string(n) + "], got " +
                                ag::to_string(mix.shape()));
  check_discriminator_loss_config(config);
  // One pass over both halves: rows 0..n-1 the demonstrations, n..2n-1 the policy's.
  std::vector<std::int64_t> both_tasks(tasks);
  both_tasks.insert(both_tasks.end(), tasks.begin(), tasks.end());
  const ag::Tensor logits = discriminator.logits_of_pairs(ag::concat({expert_pairs, policy_pairs}, 0), both_tasks);
  const ag::Tensor expert_logits = ag::narrow(logits, 0, 0, n);
  const ag::Tensor policy_logits = ag::narrow(logits, 0, n, n);
  DiscriminatorLoss loss;
  // -log D on demonstrations, -log(1 - D) on the policy's: softplus(-l) and softplus(l).
  loss.cross_entropy = (ag::mean(ag::softplus(-expert_logits)) + ag::mean(ag::softplus(policy_logits))) * 0.5;
  loss.entropy = ag::mean(bernoulli_entropy(logits));
  loss.total = loss.cross_entropy;
  if (config.entropy_bonus > 0.0) loss.total = loss.total - loss.entropy * config.entropy_bonus;
  if (config.gradient_penalty > 0.0) {
    const ag::Tensor weight = ag::reshape(mix.detach(), {n, 1});
    ag::Tensor points = (expert_pairs.detach() * weight + policy_pairs.detach() * (1.0 - weight)).detach();
    points.requires_grad_(true);
    const ag::Tensor at_points = discriminator.logits_of_pairs(points, tasks);
    const ag::Tensor slope = ag::grad({ag::sum(at_points)}, {points}, {}, std::nullopt, /*create_graph=*/true)[0];
    // The 1e-12 keeps the norm's gradient finite where D is flat.
    const ag::Tensor norm = ag::sqrt(ag::sum(ag::square(slope), {1}) + 1e-12);
    loss.penalty = ag::mean(ag::square(norm - 1.0));
    loss.total = loss.total + loss.penalty * config.gradient_penalty;
  }
  loss.expert_accuracy = share_of_sign(expert_logits, true);
  loss.policy_accuracy = share_of_sign(policy_logits, false);
  return loss;
}

const std::vector<std::string>& gail_reward_kinds() {
  static const std::vector<std::string> kinds{"gail", "log_d", "logit"};
  return kinds;
}

ag::Tensor gail_reward(const ag::Tensor& logits, const std::string& kind) {
  if (kind == "gail") return ag::softplus(logits);
  if (kind == "log_d") return -ag::softplus(-logits);
  if (kind == "logit") return logits;
  throw std::invalid_argument("gail_reward: unknown reward \"" + kind + "\" (expected gail, log_d or logit)");
}

}  // namespace maps::adversarial
