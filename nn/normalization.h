#pragma once

#include <cstdint>

#include "nn/module.h"

namespace maps::nn {

// torch::nn::LayerNorm over the last dim of size `features`: layer_norm(x) * weight + bias, weight 1 and bias 0 at
// the start.
class LayerNorm : public UnaryModule {
 public:
  explicit LayerNorm(std::int64_t features, double eps = 1e-5);
  ag::Tensor forward(const ag::Tensor& x) override;

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<LayerNorm>(*this); }

 private:
  std::int64_t features_;
  double eps_;
  std::size_t weight_ = 0, bias_ = 0;
};

// torch::nn::GroupNorm on x [batch, channels, length]: group_norm(x) times a per-channel weight [channels] plus a
// per-channel bias [channels] (1 and 0 at the start).
class GroupNorm : public UnaryModule {
 public:
  GroupNorm(std::int64_t groups, std::int64_t channels, double eps = 1e-5);
  ag::Tensor forward(const ag::Tensor& x) override;

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<GroupNorm>(*this); }

 private:
  std::int64_t groups_, channels_;
  double eps_;
  std::size_t weight_ = 0, bias_ = 0;
};

}  // namespace maps::nn
