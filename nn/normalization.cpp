#include "nn/normalization.h"

#include <stdexcept>
#include <string>

#include "nn/functional.h"

namespace maps::nn {

LayerNorm::LayerNorm(std::int64_t features, double eps) : UnaryModule("LayerNorm"), features_(features), eps_(eps) {
  if (features <= 0)
    throw std::invalid_argument("LayerNorm: features must be positive, got " + std::to_string(features));
  weight_ = register_parameter("weight", ag::full({features}, 1.0));
  bias_ = register_parameter("bias", ag::zeros({features}));
}

ag::Tensor LayerNorm::forward(const ag::Tensor& x) {
  if (!x.defined() || x.dim() < 1 || x.size(-1) != features_)
    throw std::invalid_argument("LayerNorm(" + std::to_string(features_) + ")::forward: expected input [..., " +
                                std::to_string(features_) + "], got " + ag::shape_text(x));
  return functional::layer_norm(x, 1, eps_) * parameter_at(weight_) + parameter_at(bias_);
}

GroupNorm::GroupNorm(std::int64_t groups, std::int64_t channels, double eps)
    : UnaryModule("GroupNorm"), groups_(groups), channels_(channels), eps_(eps) {
  if (groups <= 0 || channels <= 0 || channels % groups != 0)
    throw std::invalid_argument("GroupNorm: " + std::to_string(channels) + " channels do not split into " +
                                std::to_string(groups) + " groups");
  weight_ = register_parameter("weight", ag::full({channels}, 1.0));
  bias_ = register_parameter("bias", ag::zeros({channels}));
}

ag::Tensor GroupNorm::forward(const ag::Tensor& x) {
  if (!x.defined() || x.dim() != 3 || x.size(1) != channels_)
    throw std::invalid_argument("GroupNorm(" + std::to_string(groups_) + ", " + std::to_string(channels_) +
                                ")::forward: expected input [batch, " + std::to_string(channels_) + ", length], got " +
                                ag::shape_text(x));
  // Per channel: [channels] as [channels, 1], broadcast over the positions.
  return functional::group_norm(x, groups_, eps_) * ag::reshape(parameter_at(weight_), {channels_, 1}) +
         ag::reshape(parameter_at(bias_), {channels_, 1});
}

}  // namespace maps::nn
