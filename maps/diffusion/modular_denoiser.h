#pragma once

// MAPS as a denoiser (issue 46, item 3): M denoiser modules, each an MLP on the flattened noisy chunk, the denoising
// step's embedding and the condition (the last states and the task), mixed as MAPS mixes its proto-policies: a
// selector G(s, k) on the current state and the task scores them with a softmax, and a head maps the scored features
// concat(g_1 v_1, ..., g_M v_M) to the noise estimate. The selector sees neither the noisy chunk nor the step, so
// each state and task routes the same way at every denoising step, and MAPS's selector losses (share, explore,
// sparse, smooth, or a registered one) apply to its scores unchanged.

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "maps/diffusion/denoiser.h"
#include "maps/policies/policy.h"
#include "maps/selector/selector_loss.h"
#include "nn/activation.h"

namespace maps::diffusion {

struct ModularDenoiserConfig {
  std::int64_t horizon = 0;
  std::int64_t action_dim = 0;
  std::int64_t state_size = 0;  // S: the condition starts with the current state
  std::int64_t cond_dim = 0;    // C: [s, (previous s), one_hot(k)], the task's one-hot last
  std::int64_t num_tasks = 0;   // K
  std::int64_t modules = 10;    // M
  std::vector<std::int64_t> module_hidden{128, 128, 128};
  std::vector<std::int64_t> selector_hidden{128, 128};
  std::int64_t step_embed_dim = 32;
  std::string activation = "tanh";
  std::vector<std::pair<std::string, double>> selector_losses;  // name, weight
};

class ModularDenoiser : public Denoiser {
 public:
  ModularDenoiser(const ModularDenoiserConfig& config, ag::Generator& gen);

  ag::Tensor forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) override;
  // The selector's scores g(s, k) [n, M] of standardised states [n, S] under their tasks.
  ag::Tensor scores(const ag::Tensor& states, const std::vector<std::int64_t>& tasks);
  // The selector losses on a batch's states (each under every task, and the previous states under their own), each
  // weighted as configured; total undefined without losses.
  core::LossTerms selector_terms(const ag::Tensor& states, const ag::Tensor& previous_states,
                                 const std::vector<std::int64_t>& tasks);
  const ModularDenoiserConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ModularDenoiser>(*this); }

 private:
  ag::Tensor selector_scores(const ag::Tensor& states, const ag::Tensor& one_hot_tasks);

  ModularDenoiserConfig config_;
  nn::Activation activation_;
  std::size_t step_embedding_ = 0;
  std::vector<std::size_t> module_layers_;
  std::size_t selector_ = 0;
  std::size_t head_weight_ = 0;
  std::size_t head_bias_ = 0;
  std::vector<std::size_t> losses_;
  std::vector<double> loss_weights_;
};

// Its parameter count, before anything is allocated.
double modular_denoiser_parameter_count(const ModularDenoiserConfig& config);

}  // namespace maps::diffusion
