#pragma once

#include <cstdint>

#include "nn/module.h"

namespace maps::nn {

// A 1-D convolution over positions, as torch::nn::Conv1d with stride 1 and zero padding: x [batch, in, length] ->
// [batch, out, length + 2 padding - kernel + 1]; weight [out, in, kernel], bias [out]. Init like PyTorch:
// kaiming_uniform(a = sqrt(5)) for the weight, i.e. U(-1/sqrt(in kernel), 1/sqrt(in kernel)), the same bound for the
// bias; weight first, then bias, from `gen`.
class Conv1d : public UnaryModule {
 public:
  Conv1d(std::int64_t in_channels, std::int64_t out_channels, std::int64_t kernel, std::int64_t padding,
         ag::Generator& gen, bool bias = true);

  ag::Tensor forward(const ag::Tensor& x) override;

  std::int64_t in_channels() const { return in_; }
  std::int64_t out_channels() const { return out_; }
  std::int64_t kernel() const { return kernel_; }
  std::int64_t padding() const { return padding_; }
  const ag::Tensor& weight() const { return parameter_at(weight_); }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<Conv1d>(*this); }

 private:
  std::int64_t in_, out_, kernel_, padding_;
  bool has_bias_;
  std::size_t weight_ = 0;
  std::size_t bias_ = 0;
};

}  // namespace maps::nn
