#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "maps/adversarial/discriminator.h"

// The discriminator's objective and the policy's reward from it (docs/adversarial.md, with the public
// implementations' choices in ../shared/reference/beyond.md).
namespace maps::adversarial {

struct DiscriminatorLossConfig {
  // lambda E[(||grad_x logit D(x)|| - 1)^2] at points x mixed uniformly between a demonstration pair and a policy pair
  // of the same task (WGAN-GP's penalty, as ikostrikov's GAIL uses on the logit with lambda 10). 0: off.
  double gradient_penalty = 0.0;
  // Subtracts this times the mean Bernoulli entropy of D over both halves (baselines' adversary_entcoeff, 1e-3): keeps
  // D from saturating. 0: off.
  double entropy_bonus = 0.0;
};

// Throws std::invalid_argument naming the key ("config gail.gradient_penalty") out of range.
void check_discriminator_loss_config(const DiscriminatorLossConfig& config);

struct DiscriminatorLoss {
  ag::Tensor total;              // cross_entropy - entropy_bonus * entropy + gradient_penalty * penalty
  ag::Tensor cross_entropy;      // binary, demonstrations labelled 1 and the policy's pairs 0, mean over all 2n rows
  ag::Tensor entropy;            // mean Bernoulli entropy of D (nats) over all 2n rows
  ag::Tensor penalty;            // E[(||grad logit D|| - 1)^2], before its weight; undefined when the weight is 0
  double expert_accuracy = 0.0;  // share of demonstration rows with D > 1/2
  double policy_accuracy = 0.0;  // share of the policy's rows with D < 1/2
};

// `expert_pairs` and `policy_pairs` are [n, S + A] (standardised observations beside actions) whose row i is of task
// tasks[i] in both; `mix` [n] (in [0, 1]) places the penalty's points, expert * mix + policy * (1 - mix). The
// penalty is differentiated with create_graph, so total's gradient reaches the parameters through it.
DiscriminatorLoss discriminator_loss(Discriminator& discriminator, const ag::Tensor& expert_pairs,
                                     const ag::Tensor& policy_pairs, const std::vector<std::int64_t>& tasks,
                                     const DiscriminatorLossConfig& config, const ag::Tensor& mix);

// The policy's reward for logits l [n]: "gail" -log(1 - D) = softplus(l) (positive; imitation's and baselines'),
// "log_d" log D = -softplus(-l) (negative), "logit" l = log D - log(1 - D) (ikostrikov's, AIRL's form).
ag::Tensor gail_reward(const ag::Tensor& logits, const std::string& kind);
// The reward kinds, for config checks and help: "gail, log_d, logit".
const std::vector<std::string>& gail_reward_kinds();

}  // namespace maps::adversarial
