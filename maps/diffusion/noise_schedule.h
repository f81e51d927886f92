#pragma once

// The diffusion process of Diffusion Policy (Chi et al., RSS 2023; issue 46): DDPM's forward noising with the
// "squaredcos_cap_v2" schedule and epsilon prediction, the DDPM ancestral step (its "fixed_small" variance) and the
// deterministic DDIM step (eta = 0) with diffusers' "leading" timestep spacing, both clipping the predicted clean
// sample to [-1, 1] as Diffusion Policy's configs do (its actions are normalised to that range).

#include <cstdint>
#include <vector>

#include "autograd/autograd.h"

namespace maps::diffusion {

class NoiseSchedule {
 public:
  // T training steps: beta_t = min(1 - abar(t + 1) / abar(t), 0.999) with abar(u) = cos((u / T + 0.008) / 1.008
  // pi / 2)^2 (Nichol and Dhariwal's cosine schedule, diffusers' betas_for_alpha_bar), t = 0 .. T - 1.
  explicit NoiseSchedule(int training_steps);

  int training_steps() const { return static_cast<int>(betas_.size()); }
  double beta(int t) const;
  double alpha_bar(int t) const;  // prod_{s <= t} (1 - beta_s)

  // x_t = sqrt(abar_t) x0 + sqrt(1 - abar_t) noise, row i at timesteps[i]; x0 and noise [rows, ...] alike.
  ag::Tensor add_noise(const ag::Tensor& x0, const ag::Tensor& noise, const std::vector<int>& timesteps) const;

  // The timesteps a DDIM sampler of `inference_steps` visits, from the noisiest: (S - 1) r, ..., r, 0 with
  // r = T / S (integer division), as diffusers' "leading" spacing; S in [1, T].
  std::vector<int> ddim_timesteps(int inference_steps) const;

  // One DDIM step (eta = 0) from x_t at t to the previous timestep `previous` (-1: the clean sample, abar = 1) given
  // the denoiser's noise estimate: x0 = (x_t - sqrt(1 - abar_t) eps) / sqrt(abar_t), clipped to [-1, 1] with `clip`
  // (eps then re-derived from the clipped x0), and x_prev = sqrt(abar_prev) x0 + sqrt(1 - abar_prev) eps.
  ag::Tensor ddim_step(const ag::Tensor& x_t, const ag::Tensor& noise_estimate, int t, int previous, bool clip) const;

  // One DDPM step from t to t - 1: the posterior mean given the (clipped) x0 estimate, plus sqrt(variance) times
  // `noise` where t > 0, variance (1 - abar_{t-1}) / (1 - abar_t) beta_t ("fixed_small").
  ag::Tensor ddpm_step(const ag::Tensor& x_t, const ag::Tensor& noise_estimate, int t, const ag::Tensor& noise,
                       bool clip) const;

 private:
  void check_timestep(int t, const char* what) const;
  std::vector<double> betas_;
  std::vector<double> alpha_bars_;
};

}  // namespace maps::diffusion
