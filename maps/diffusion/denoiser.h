#pragma once

// What a diffusion policy's denoiser is (issue 46): the noise estimate for a batch of noisy action chunks at their
// denoising steps, given a condition per row (the observations and the task). The U-Net and the MLP implement it.

#include <vector>

#include "nn/module.h"

namespace maps::diffusion {

class Denoiser : public nn::Module {
 public:
  using nn::Module::Module;
  // noisy [B, H, A], one step per row, cond [B, C] -> [B, H, A].
  virtual ag::Tensor forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) = 0;

 protected:
  Denoiser(const Denoiser&) = default;
};

}  // namespace maps::diffusion
