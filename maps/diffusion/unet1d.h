#pragma once

// Diffusion Policy's conditional 1-D U-Net over a chunk of actions (ConditionalUnet1D with global conditioning and
// cond_predict_scale; issue 46), on nn's layers. Departure: each upsampling is nearest-neighbour x2 then a
// Conv1d(k 3, padding 1), where the paper has ConvTranspose1d(k 4, stride 2, padding 1); the downsampling is the
// paper's (Conv1d k 3 stride 2 padding 1, as a stride-1 convolution then every other position).

#include <cstdint>
#include <memory>
#include <vector>

#include "maps/diffusion/conditional_blocks.h"
#include "maps/diffusion/denoiser.h"

namespace maps::diffusion {

struct Unet1dConfig {
  std::int64_t action_dim = 0;
  std::int64_t cond_dim = 0;  // the condition beside the step's embedding (observations, task one-hot)
  std::int64_t step_embed_dim = 256;
  std::vector<std::int64_t> down_dims{256, 512, 1024};  // Diffusion Policy's low-dimensional defaults
  std::int64_t kernel = 5;
  std::int64_t groups = 8;
};

class ConditionalUnet1d : public Denoiser {
 public:
  ConditionalUnet1d(const Unet1dConfig& config, ag::Generator& gen);

  // The noise estimate for `noisy` [B, H, action_dim] at the denoising steps (one per row) given cond [B, cond_dim]:
  // [B, H, action_dim]. H must divide by 2^(levels - 1).
  ag::Tensor forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) override;

  const Unet1dConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ConditionalUnet1d>(*this); }

 private:
  struct Level {
    std::size_t first, second, resample;  // resample: a Conv1d slot, or kNone at the last level
  };
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  Unet1dConfig config_;
  std::size_t step_embedding_ = 0;
  std::vector<Level> down_, up_;
  std::size_t mid_first_ = 0, mid_second_ = 0, final_block_ = 0, final_conv_ = 0;
};

}  // namespace maps::diffusion
