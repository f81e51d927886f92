#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "nn/module.h"

// GAIL's discriminator D(s, a, task) (Ho and Ermon, 2016): an MLP whose logit is high for the demonstrations'
// state-action pairs and low for the policy's, trained with binary cross-entropy; its reward -log(1 - D) drives the
// policy (docs/adversarial.md).
namespace maps::adversarial {

struct DiscriminatorConfig {
  std::vector<std::int64_t> hidden = {100, 100};  // ikostrikov's and baselines' 2 x 100
  std::string activation = "tanh";
  // How the task enters. "input": one_hot(task) beside (s, a), one logit. "heads": the MLP sees (s, a) alone and
  // ends in one logit per task, of which a row's own task's is taken (a discriminator per task sharing its trunk).
  std::string conditioning = "input";
};

// Throws std::invalid_argument naming the key ("config gail.discriminator_hidden: ...") when a field is out of range.
void check_discriminator_config(const DiscriminatorConfig& config);

class Discriminator : public nn::Module {
 public:
  Discriminator(const DiscriminatorConfig& config, std::int64_t observation_size, std::int64_t action_size,
                std::int64_t num_tasks, ag::Generator& gen);

  // Logits [n] for standardised observations [n, S], actions [n, A] and task ids [n].
  ag::Tensor logits(const ag::Tensor& observations, const ag::Tensor& actions, const std::vector<std::int64_t>& tasks);
  // The same on (s, a) already side by side, [n, S + A] (the gradient penalty differentiates through it).
  ag::Tensor logits_of_pairs(const ag::Tensor& pairs, const std::vector<std::int64_t>& tasks);

  const DiscriminatorConfig& config() const { return config_; }
  std::int64_t observation_size() const { return observation_size_; }
  std::int64_t action_size() const { return action_size_; }
  std::int64_t num_tasks() const { return num_tasks_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Discriminator>(*this); }

 private:
  DiscriminatorConfig config_;
  std::int64_t observation_size_, action_size_, num_tasks_;
  std::size_t mlp_ = 0;
};

}  // namespace maps::adversarial
