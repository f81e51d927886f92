#include "maps/diffusion/mlp_denoiser.h"

#include <stdexcept>
#include <string>

namespace maps::diffusion {

MlpDenoiser::MlpDenoiser(const MlpDenoiserConfig& config, ag::Generator& gen)
    : Denoiser("MlpDenoiser"), config_(config) {
  if (config.horizon < 1 || config.action_dim < 1 || config.cond_dim < 0 || config.hidden.empty())
    throw std::invalid_argument(
        "MlpDenoiser: horizon and action_dim must be positive, cond_dim >= 0, hidden not empty");
  step_embedding_ = register_module("step_embedding", std::make_shared<StepEmbedding>(config.step_embed_dim, gen));
  const std::vector<std::int64_t> sizes = flat_denoiser_layer_sizes(
      config.horizon, config.action_dim, config.step_embed_dim, config.cond_dim, config.hidden);
  for (std::size_t i = 0; i + 1 < sizes.size(); ++i)
    layers_.push_back(
        register_module("layer" + std::to_string(i), std::make_shared<nn::Linear>(sizes[i], sizes[i + 1], gen)));
}

ag::Tensor MlpDenoiser::forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) {
  ag::Tensor x = flat_denoiser_input("MlpDenoiser", noisy, steps, cond, config_.horizon, config_.action_dim,
                                     config_.cond_dim, child_at<StepEmbedding>(step_embedding_));
  for (std::size_t i = 0; i < layers_.size(); ++i) {
    x = child_at<nn::Linear>(layers_[i]).forward(x);
    if (i + 1 < layers_.size()) x = ag::mish(x);
  }
  return ag::reshape(x, noisy.shape());
}

}  // namespace maps::diffusion
