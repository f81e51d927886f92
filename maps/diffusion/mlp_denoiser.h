#pragma once

// An MLP denoiser (issue 46): the flattened noisy chunk, the step's embedding and the condition side by side through
// Linear layers with Mish between them, out to the chunk's size. Diffusion Policy ships no MLP denoiser for
// low-dimensional states (../shared/reference/beyond.md): this is the simplest one, the U-Net's step embedding
// (StepEmbedding) beside a plain MLP.

#include <cstdint>
#include <memory>
#include <vector>

#include "maps/diffusion/conditional_blocks.h"
#include "maps/diffusion/denoiser.h"

namespace maps::diffusion {

struct MlpDenoiserConfig {
  std::int64_t horizon = 0;
  std::int64_t action_dim = 0;
  std::int64_t cond_dim = 0;
  std::int64_t step_embed_dim = 64;
  std::vector<std::int64_t> hidden{256, 256, 256};
};

class MlpDenoiser : public Denoiser {
 public:
  MlpDenoiser(const MlpDenoiserConfig& config, ag::Generator& gen);
  ag::Tensor forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) override;
  const MlpDenoiserConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<MlpDenoiser>(*this); }

 private:
  MlpDenoiserConfig config_;
  std::size_t step_embedding_ = 0;
  std::vector<std::size_t> layers_;
};

}  // namespace maps::diffusion
