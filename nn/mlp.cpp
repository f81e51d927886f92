#include "nn/mlp.h"

#include <stdexcept>

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

ag::Tensor MLP::forward(const ag::Tensor& x) {
  const auto& layers = child_at<ModuleList>(layers_);
  ag::Tensor y = x;
  const std::size_t n = layers.size();
  for (std::size_t i = 0; i < n; ++i) {
    y = layers.at<Linear>(i).forward(y);
    if (i + 1 < n || activate_last_) y = apply_activation(activation_, y);
  }
  return y;
}

}  // namespace maps::nn
