#pragma once

// Training and sampling a denoiser (Diffusion Policy's recipe; issue 46).

#include <cstdint>

#include "maps/diffusion/denoiser.h"
#include "maps/diffusion/noise_schedule.h"

namespace maps::diffusion {

// Diffusion Policy's loss: per row a step t uniform in [0, T) and noise ~ N(0, I); the mean squared error between
// the denoiser's estimate at add_noise(chunk, noise, t) and that noise, over every element. chunks [B, H, A] (in
// [-1, 1], normalised), cond [B, C].
ag::Tensor denoising_loss(Denoiser& denoiser, const NoiseSchedule& schedule, const ag::Tensor& chunks,
                          const ag::Tensor& cond, ag::Generator& gen);

// B chunks [B, H, action_dim] drawn by DDIM (eta = 0) from N(0, I), B = cond's rows: one batched denoiser call per
// inference step for every row, without recording a graph.
ag::Tensor sample_ddim(Denoiser& denoiser, const NoiseSchedule& schedule, const ag::Tensor& cond, std::int64_t horizon,
                       std::int64_t action_dim, int inference_steps, bool clip, ag::Generator& gen);
// The same from a given starting noise [B, H, action_dim] (a policy drawing each row's noise from its own stream).
ag::Tensor sample_ddim_from(Denoiser& denoiser, const NoiseSchedule& schedule, const ag::Tensor& cond,
                            const ag::Tensor& noise, int inference_steps, bool clip);

}  // namespace maps::diffusion
