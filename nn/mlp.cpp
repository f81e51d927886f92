#include "nn/mlp.h"

#include <optional>
#include <stdexcept>
#include <string>

#include "nn/linear.h"
#include "nn/module_list.h"

namespace maps::nn {

MLP::MLP(const std::vector<std::int64_t>& sizes, Activation activation, ag::Generator& gen, bool activate_last)
    : UnaryModule("MLP"), sizes_(sizes), activation_(activation), activate_last_(activate_last) {
  if (sizes_.size() < 2)
    throw std::invalid_argument("MLP: sizes must hold at least {in, out}, got " + ag::to_string(sizes_));
  for (std::int64_t s : sizes_)
    if (s <= 0) throw std::invalid_argument("MLP: every size must be positive, got " + ag::to_string(sizes_));
  auto layers = std::make_shared<ModuleList>();
  for (std::size_t i = 0; i + 1 < sizes_.size(); ++i)
    layers->push_back(std::make_shared<Linear>(sizes_[i], sizes_[i + 1], gen));
  layers_ = register_module("layers", layers);
}

MLP::MLP(const std::vector<std::int64_t>& sizes, const std::string& activation, ag::Generator& gen, bool activate_last)
    : MLP(sizes, activation_from_name(activation), gen, activate_last) {}

ag::Tensor MLP::forward(const ag::Tensor& x) { return forward_from(0, x); }

ag::Tensor MLP::forward_from(std::size_t first, const ag::Tensor& x) {
  auto& layers = child_at<ModuleList>(layers_);
  const std::size_t n = layers.size();
  if (first >= n)
    throw std::out_of_range("MLP::forward_from: layer " + std::to_string(first) + " of " + std::to_string(n));
  const std::optional<ag::Fused> hidden = fused_activation(activation_);
  if (hidden && x.defined() && (x.dim() == 2 || x.dim() == 3) && x.size(-1) == sizes_[first]) {
    // The layers as one op, block of rows by block of rows (autograd/ops.h).
    std::vector<ag::Tensor> weights, biases;
    for (std::size_t i = first; i < n; ++i) {
      const Linear& layer = layers.at<Linear>(i);
      weights.push_back(layer.weight());
      if (layer.has_bias()) biases.push_back(layer.bias());
    }
    if (biases.empty() || biases.size() == weights.size()) {
      const ag::Tensor rows = x.dim() == 2 ? x : x.reshape({-1, x.size(-1)});
      const ag::Tensor y = ag::mlp(rows, weights, biases, *hidden, activate_last_ ? *hidden : ag::Fused::None);
      return x.dim() == 2 ? y : y.reshape({x.size(0), x.size(1), sizes_.back()});
    }
  }
  ag::Tensor y = x;
  for (std::size_t i = first; i < n; ++i)
    y = layers.at<Linear>(i).forward_activated(y, i + 1 < n || activate_last_ ? activation_ : Activation::Identity);
  return y;
}

Linear& MLP::layer(std::size_t i) {
  auto& layers = child_at<ModuleList>(layers_);
  if (i >= layers.size())
    throw std::out_of_range("MLP::layer: layer " + std::to_string(i) + " of " + std::to_string(layers.size()));
  return layers.at<Linear>(i);
}

}  // namespace maps::nn
