#pragma once

#include <cstdint>

#include "nn/activation.h"
#include "nn/module.h"

namespace maps::nn {

// y = x W^T + b, as torch::nn::Linear. weight [out, in], bias [out].
// Init like PyTorch: kaiming_uniform(a = sqrt(5)) for the weight, i.e. U(-1/sqrt(in), 1/sqrt(in)), and the
// same bound for the bias; weight first, then bias, drawn from `gen` in row-major order.
class Linear : public UnaryModule {
 public:
  Linear(std::int64_t in_features, std::int64_t out_features, ag::Generator& gen, bool bias = true);

  // x [..., in] (2-d or 3-d) -> [..., out].
  ag::Tensor forward(const ag::Tensor& x) override;
  // activation(forward(x)), tanh fused into the layer's op (one pass over the output instead of two).
  ag::Tensor forward_activated(const ag::Tensor& x, Activation activation);

  std::int64_t in_features() const { return in_; }
  std::int64_t out_features() const { return out_; }
  bool has_bias() const { return has_bias_; }
  const ag::Tensor& weight() const { return parameter_at(weight_); }
  const ag::Tensor& bias() const;  // throws when built without bias

  // Redraws the parameters with the constructor's rule.
  void reset_parameters(ag::Generator& gen);

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Linear>(*this); }

 private:
  std::int64_t in_;
  std::int64_t out_;
  bool has_bias_;
  std::size_t weight_ = 0;
  std::size_t bias_ = 0;
};

}  // namespace maps::nn
