#pragma once

// The building blocks of Diffusion Policy's conditional 1-D U-Net (conditional_unet1d.py; issue 46), on nn's layers.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "nn/nn.h"

namespace maps::diffusion {

// The denoising step as a vector: sinusoidal(dim) -> Linear(dim, 4 dim) -> Mish -> Linear(4 dim, dim).
class StepEmbedding : public nn::Module {
 public:
  StepEmbedding(std::int64_t dim, ag::Generator& gen);
  // One row per step: [steps, dim], in the module's dtype.
  ag::Tensor forward(const std::vector<int>& steps);
  std::int64_t dim() const { return dim_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<StepEmbedding>(*this); }

 private:
  std::int64_t dim_;
  std::size_t first_ = 0, second_ = 0;
};

// Its parameters: sinusoidal(dim) -> Linear 4 dim -> Mish -> Linear dim.
double step_embedding_parameter_count(std::int64_t dim);

// A flat denoiser's layer sizes: [H A + step embedding + cond, hidden..., H A] (the MLP denoiser, each top-k MoE
// expert; MAPS's modules stop at their last hidden layer, the head being MAPS's).
std::vector<std::int64_t> flat_denoiser_layer_sizes(std::int64_t horizon, std::int64_t action_dim,
                                                    std::int64_t step_embed_dim, std::int64_t cond_dim,
                                                    const std::vector<std::int64_t>& hidden);

// The input of the flat denoisers (MLP, MAPS's, the top-k MoE): [noisy chunk flattened, the steps' embedding, cond]
// [B, H A + E + C], after checking noisy [B, horizon, action_dim], one step per row and cond [B, cond_dim]; a
// mismatch is an error naming `who` and both shapes.
ag::Tensor flat_denoiser_input(const std::string& who, const ag::Tensor& noisy, const std::vector<int>& steps,
                               const ag::Tensor& cond, std::int64_t horizon, std::int64_t action_dim,
                               std::int64_t cond_dim, StepEmbedding& embedding);

// Conv1d(in, out, k, padding k / 2) -> GroupNorm(groups, out) -> Mish: [B, in, L] -> [B, out, L].
class ConvBlock1d : public nn::UnaryModule {
 public:
  ConvBlock1d(std::int64_t in, std::int64_t out, std::int64_t kernel, std::int64_t groups, ag::Generator& gen);
  ag::Tensor forward(const ag::Tensor& x) override;

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ConvBlock1d>(*this); }

 private:
  std::size_t conv_ = 0, norm_ = 0;
};

// Two ConvBlock1d with FiLM between them: the condition c [B, cond] through Mish -> Linear(cond, 2 out) gives a
// per-channel scale and bias, h = scale * block1(x) + bias; then block2(h) plus x (through a 1 x 1 Conv1d when in !=
// out). Diffusion Policy's ConditionalResidualBlock1D with cond_predict_scale.
class ConditionalResidualBlock1d : public nn::Module {
 public:
  ConditionalResidualBlock1d(std::int64_t in, std::int64_t out, std::int64_t cond, std::int64_t kernel,
                             std::int64_t groups, ag::Generator& gen);
  ag::Tensor forward(const ag::Tensor& x, const ag::Tensor& cond);
  std::int64_t out_channels() const { return out_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ConditionalResidualBlock1d>(*this); }

 private:
  std::int64_t in_, out_, cond_;
  std::size_t first_ = 0, second_ = 0, film_ = 0, residual_ = 0;
  bool has_residual_conv_;
};

}  // namespace maps::diffusion
