#include "maps/diffusion/conditional_blocks.h"

#include <stdexcept>
#include <string>

namespace maps::diffusion {

StepEmbedding::StepEmbedding(std::int64_t dim, ag::Generator& gen) : nn::Module("StepEmbedding"), dim_(dim) {
  if (dim < 4 || dim % 2 != 0)
    throw std::invalid_argument("StepEmbedding: dim must be even and at least 4, got " + std::to_string(dim));
  first_ = register_module("first", std::make_shared<nn::Linear>(dim, 4 * dim, gen));
  second_ = register_module("second", std::make_shared<nn::Linear>(4 * dim, dim, gen));
}

ag::Tensor StepEmbedding::forward(const std::vector<int>& steps) {
  auto& first = child_at<nn::Linear>(first_);
  const std::vector<double> as_double(steps.begin(), steps.end());
  const ag::Tensor sinusoid = nn::functional::sinusoidal_embedding(as_double, dim_, first.weight().dtype());
  return child_at<nn::Linear>(second_).forward(ag::mish(first.forward(sinusoid)));
}

ConvBlock1d::ConvBlock1d(std::int64_t in, std::int64_t out, std::int64_t kernel, std::int64_t groups,
                         ag::Generator& gen)
    : nn::UnaryModule("ConvBlock1d") {
  if (kernel % 2 != 1)
    throw std::invalid_argument("ConvBlock1d: the kernel must be odd (the length is kept), got " +
                                std::to_string(kernel));
  conv_ = register_module("conv", std::make_shared<nn::Conv1d>(in, out, kernel, kernel / 2, gen));
  norm_ = register_module("norm", std::make_shared<nn::GroupNorm>(groups, out));
}

ag::Tensor ConvBlock1d::forward(const ag::Tensor& x) {
  return ag::mish(child_at<nn::GroupNorm>(norm_).forward(child_at<nn::Conv1d>(conv_).forward(x)));
}

ConditionalResidualBlock1d::ConditionalResidualBlock1d(std::int64_t in, std::int64_t out, std::int64_t cond,
                                                       std::int64_t kernel, std::int64_t groups, ag::Generator& gen)
    : nn::Module("ConditionalResidualBlock1d"), in_(in), out_(out), cond_(cond), has_residual_conv_(in != out) {
  first_ = register_module("first", std::make_shared<ConvBlock1d>(in, out, kernel, groups, gen));
  second_ = register_module("second", std::make_shared<ConvBlock1d>(out, out, kernel, groups, gen));
  film_ = register_module("film", std::make_shared<nn::Linear>(cond, 2 * out, gen));
  if (has_residual_conv_) residual_ = register_module("residual", std::make_shared<nn::Conv1d>(in, out, 1, 0, gen));
}

ag::Tensor ConditionalResidualBlock1d::forward(const ag::Tensor& x, const ag::Tensor& cond) {
  if (x.dim() != 3 || x.size(1) != in_ || cond.dim() != 2 || cond.size(1) != cond_ || cond.size(0) != x.size(0))
    throw std::invalid_argument("ConditionalResidualBlock1d(" + std::to_string(in_) + " -> " + std::to_string(out_) +
                                "): expected x [batch, " + std::to_string(in_) + ", length] and cond [batch, " +
                                std::to_string(cond_) + "], got " + ag::to_string(x.shape()) + " and " +
                                ag::to_string(cond.shape()));
  const ag::Tensor h = child_at<ConvBlock1d>(first_).forward(x);
  // [B, 2 out] -> a scale and a bias per channel, broadcast over the positions.
  const ag::Tensor film = ag::reshape(child_at<nn::Linear>(film_).forward(ag::mish(cond)), {x.size(0), 2, out_, 1});
  const ag::Tensor scale = ag::reshape(ag::narrow(film, 1, 0, 1), {x.size(0), out_, 1});
  const ag::Tensor bias = ag::reshape(ag::narrow(film, 1, 1, 1), {x.size(0), out_, 1});
  const ag::Tensor shortcut = has_residual_conv_ ? child_at<nn::Conv1d>(residual_).forward(x) : x;
  return child_at<ConvBlock1d>(second_).forward(scale * h + bias) + shortcut;
}

double step_embedding_parameter_count(std::int64_t dim) {
  const double d = static_cast<double>(dim);
  return d * 4 * d + 4 * d + 4 * d * d + d;
}

std::vector<std::int64_t> flat_denoiser_layer_sizes(std::int64_t horizon, std::int64_t action_dim,
                                                    std::int64_t step_embed_dim, std::int64_t cond_dim,
                                                    const std::vector<std::int64_t>& hidden) {
  std::vector<std::int64_t> sizes{horizon * action_dim + step_embed_dim + cond_dim};
  sizes.insert(sizes.end(), hidden.begin(), hidden.end());
  sizes.push_back(horizon * action_dim);
  return sizes;
}

ag::Tensor flat_denoiser_input(const std::string& who, const ag::Tensor& noisy, const std::vector<int>& steps,
                               const ag::Tensor& cond, std::int64_t horizon, std::int64_t action_dim,
                               std::int64_t cond_dim, StepEmbedding& embedding) {
  if (noisy.dim() != 3 || noisy.size(1) != horizon || noisy.size(2) != action_dim ||
      static_cast<std::size_t>(noisy.size(0)) != steps.size() || cond.dim() != 2 || cond.size(0) != noisy.size(0) ||
      cond.size(1) != cond_dim)
    throw std::invalid_argument(who + ": expected noisy [batch, " + std::to_string(horizon) + ", " +
                                std::to_string(action_dim) + "], one step per row and cond [batch, " +
                                std::to_string(cond_dim) + "], got " + ag::to_string(noisy.shape()) + ", " +
                                std::to_string(steps.size()) + " steps and " + ag::to_string(cond.shape()));
  return ag::concat(
      {ag::reshape(noisy, {noisy.size(0), horizon * action_dim}), embedding.forward(steps).to(noisy.dtype()), cond}, 1);
}

}  // namespace maps::diffusion
