#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "maps/diffusion/denoiser.h"
#include "maps/diffusion/noise_schedule.h"
#include "maps/policies/maps_policy.h"
#include "maps/policies/policy.h"

// State-based Diffusion Policy (Chi et al., RSS 2023; issue 46, docs/zoo.md) as a zoo method: a denoiser over a chunk
// of the next H actions, conditioned on the last one or two observations and the task (one-hot), trained by DDPM's
// noise-prediction loss and sampled by DDIM; executed open loop, `execute` actions per chunk (the receding horizon).
// Actions are targets in the envs' box [-1, 1] (demonstrations clipped to it; Diffusion Policy normalises each
// dimension's data range to [-1, 1] instead). Sampling is deterministic: each row's starting noise comes from a
// stream seeded by its observations and task, so an evaluation is the same whatever the batch or thread count.
// Parameters: "denoiser.<...>" (the U-Net's or the MLP's names).
namespace maps::core {

struct DiffusionPolicyConfig {
  // "unet": the conditional 1-D U-Net; "mlp": MlpDenoiser; "maps": ModularDenoiser, MAPS's modules and selector
  // (issue 46, item 3) with maps.* settings (modules, selector, activation, selector losses and the two weights);
  // "moe": SparseMoeDenoiser, top-k experts after Sparse Diffusion Policy.
  std::string denoiser = "unet";
  // U-Net: down_dims [w, 2w, 4w] with step embedding w (Diffusion Policy's low-dimensional U-Net is w = 256); MLP:
  // `layers` hidden layers of width w, step embedding 2 max(8, floor(w / 8)); MAPS: each module's layers (as many as
  // maps.module_hidden) of width w, the same step embedding.
  std::int64_t width = 256;
  std::int64_t layers = 3;  // MLP only
  std::int64_t horizon = 16;
  std::int64_t execute = 8;
  std::int64_t observations = 2;  // 1: the current state; 2: the previous one too (n_obs_steps)
  int training_steps = 100;
  int inference_steps = 8;  // DDIM's
  bool clip = true;         // clip the predicted clean chunk to [-1, 1] at each step
  MAPSConfig maps;          // the "maps" denoiser's modules, selector and losses
  // The "moe" denoiser: experts (each `layers` hidden layers of width w), kept per row, and the weight of the
  // negative task-expert mutual information in the loss (SDP: 8, 2, 5e-4).
  std::int64_t experts = 8;
  std::int64_t top_k = 2;
  double mutual_information_weight = 5e-4;
};

class DiffusionPolicy : public Policy {
 public:
  // shape.action_size is the chunk's: horizon x the env's action size.
  DiffusionPolicy(PolicyShape shape, const DiffusionPolicyConfig& config, ag::Generator& gen);

  // The chunk [n, H * A] for the current states alone (the previous taken equal to them, as at t = 0).
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  ag::Tensor act_with_history(const ag::Tensor& observations, const ag::Tensor& previous_observations,
                              const std::vector<std::int64_t>& tasks) override;
  // terms {"denoise"}: the mean squared error of the noise estimate, at a step and noise per row from the batch's
  // noise seed; with the "maps" denoiser also its selector losses, total = maps.bc_weight x denoise +
  // maps.selector_weight x sum_j lambda_j L_j (MAPS's weighting, the denoising loss in the BC loss's place).
  LossTerms loss(const Batch& batch) override;
  // The "maps" denoiser's selector scores; the "moe" denoiser's gates of each row's top k, scaled to sum 1 (the
  // experts' shares in the row's estimate); undefined for the others.
  ag::Tensor routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  std::int64_t routed_modules() const override;
  // The denoising loss on the validation rows at steps and noise from a fixed seed (the same at every
  // validation, so checkpoints compare on the same draw), in chunks of rows, without gradients.
  double validation_loss(const Batch& validation, const DemoDataset& data) override;

  const DiffusionPolicyConfig& config() const { return config_; }
  std::int64_t step_action_dim() const { return action_dim_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<DiffusionPolicy>(*this); }

 private:
  ag::Tensor condition(const ag::Tensor& observations, const ag::Tensor& previous_observations,
                       const std::vector<std::int64_t>& tasks) const;
  ag::Tensor chunks_of(const Batch& batch) const;  // [n, H, A] clipped to [-1, 1]
  diffusion::Denoiser& denoiser() const { return child_at<diffusion::Denoiser>(denoiser_); }

  DiffusionPolicyConfig config_;
  std::int64_t action_dim_ = 0;
  diffusion::NoiseSchedule schedule_;
  std::size_t denoiser_ = 0;
};

// The parameter count for these shapes (shape.action_size the chunk's), before anything is allocated.
double diffusion_policy_parameter_count(const PolicyShape& shape, const DiffusionPolicyConfig& config);

}  // namespace maps::core
