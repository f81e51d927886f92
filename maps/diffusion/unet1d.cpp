#include "maps/diffusion/unet1d.h"

#include <stdexcept>
#include <string>

namespace maps::diffusion {

ConditionalUnet1d::ConditionalUnet1d(const Unet1dConfig& config, ag::Generator& gen)
    : Denoiser("ConditionalUnet1d"), config_(config) {
  if (config.action_dim < 1 || config.cond_dim < 0 || config.down_dims.empty() || config.kernel < 1)
    throw std::invalid_argument("ConditionalUnet1d: action_dim must be positive, cond_dim >= 0, down_dims not empty");
  const std::int64_t cond = config.step_embed_dim + config.cond_dim;
  const auto block = [&](std::int64_t in, std::int64_t out) {
    return std::make_shared<ConditionalResidualBlock1d>(in, out, cond, config.kernel, config.groups, gen);
  };
  step_embedding_ = register_module("step_embedding", std::make_shared<StepEmbedding>(config.step_embed_dim, gen));
  const auto& dims = config.down_dims;
  const std::size_t levels = dims.size();
  for (std::size_t i = 0; i < levels; ++i) {
    const std::int64_t in = i == 0 ? config.action_dim : dims[i - 1];
    const std::string name = "down" + std::to_string(i);
    Level level{register_module(name + "_first", block(in, dims[i])),
                register_module(name + "_second", block(dims[i], dims[i])), kNone};
    if (i + 1 < levels)
      level.resample = register_module(name + "_downsample", std::make_shared<nn::Conv1d>(dims[i], dims[i], 3, 1, gen));
    down_.push_back(level);
  }
  mid_first_ = register_module("mid_first", block(dims.back(), dims.back()));
  mid_second_ = register_module("mid_second", block(dims.back(), dims.back()));
  for (std::size_t j = levels - 1; j >= 1; --j) {
    const std::string name = "up" + std::to_string(levels - 1 - j);
    up_.push_back(
        {register_module(name + "_first", block(2 * dims[j], dims[j - 1])),
         register_module(name + "_second", block(dims[j - 1], dims[j - 1])),
         register_module(name + "_upsample", std::make_shared<nn::Conv1d>(dims[j - 1], dims[j - 1], 3, 1, gen))});
  }
  final_block_ = register_module("final_block",
                                 std::make_shared<ConvBlock1d>(dims[0], dims[0], config.kernel, config.groups, gen));
  final_conv_ = register_module("final_conv", std::make_shared<nn::Conv1d>(dims[0], config.action_dim, 1, 0, gen));
}

ag::Tensor ConditionalUnet1d::forward(const ag::Tensor& noisy, const std::vector<int>& steps, const ag::Tensor& cond) {
  const std::int64_t scale = std::int64_t{1} << (down_.size() - 1);
  if (noisy.dim() != 3 || noisy.size(2) != config_.action_dim || noisy.size(1) % scale != 0 ||
      static_cast<std::size_t>(noisy.size(0)) != steps.size() || cond.dim() != 2 || cond.size(0) != noisy.size(0) ||
      cond.size(1) != config_.cond_dim)
    throw std::invalid_argument("ConditionalUnet1d: expected noisy [batch, horizon divisible by " +
                                std::to_string(scale) + ", " + std::to_string(config_.action_dim) +
                                "], one step per row and cond [batch, " + std::to_string(config_.cond_dim) + "], got " +
                                ag::to_string(noisy.shape()) + ", " + std::to_string(steps.size()) + " steps and " +
                                ag::to_string(cond.shape()));
  const ag::Tensor global = ag::concat({child_at<StepEmbedding>(step_embedding_).forward(steps), cond}, 1);
  ag::Tensor x = ag::transpose(noisy, 1, 2);  // [B, A, H]: channels before positions
  std::vector<ag::Tensor> skips;
  for (const Level& level : down_) {
    x = child_at<ConditionalResidualBlock1d>(level.first).forward(x, global);
    x = child_at<ConditionalResidualBlock1d>(level.second).forward(x, global);
    skips.push_back(x);
    if (level.resample != kNone) x = nn::functional::downsample2(child_at<nn::Conv1d>(level.resample).forward(x));
  }
  x = child_at<ConditionalResidualBlock1d>(mid_first_).forward(x, global);
  x = child_at<ConditionalResidualBlock1d>(mid_second_).forward(x, global);
  for (const Level& level : up_) {
    x = ag::concat({x, skips.back()}, 1);
    skips.pop_back();
    x = child_at<ConditionalResidualBlock1d>(level.first).forward(x, global);
    x = child_at<ConditionalResidualBlock1d>(level.second).forward(x, global);
    x = child_at<nn::Conv1d>(level.resample).forward(nn::functional::upsample2(x));
  }
  x = child_at<nn::Conv1d>(final_conv_).forward(child_at<ConvBlock1d>(final_block_).forward(x));
  return ag::transpose(x, 1, 2);
}

}  // namespace maps::diffusion
