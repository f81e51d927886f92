#pragma once

#include <cstdint>

#include "nn/activation.h"
#include "nn/module.h"

namespace maps::nn {

// M independent linear layers evaluated as one batched GEMM (the building block of MAPS's per-task heads).
// weight [M, in, out] (each slice is the transpose of a Linear's weight), bias [M, 1, out].
//
// forward:
//   x [M, B, in] -> [M, B, out]: y_m = x_m W_m + b_m, one batched matmul.
//   x [B, in]    -> [M, B, out]: the same input for every layer, read in place by each layer's GEMM. (A single
//                   [B, in] @ [in, M*out] GEMM would need two transposing copies, of the weight and of the output,
//                   which cost more at MAPS's sizes.)
// Both are one ag::parallel_linear op: the bias starts each output and the layers' GEMMs add to it; the threads
// share out the layers.
//
// Init: layer m gets exactly the values a Linear(in, out) would draw next from `gen` (weight [out, in] in
// row-major order, then bias), layers in order 0..M-1; so ParallelLinear(M, in, out, gen) equals M Linears
// built one after the other from a generator with the same state.
class ParallelLinear : public UnaryModule {
 public:
  ParallelLinear(std::int64_t members, std::int64_t in_features, std::int64_t out_features, ag::Generator& gen,
                 bool bias = true);

  ag::Tensor forward(const ag::Tensor& x) override;
  // activation(forward(x)), tanh fused into the layer's op (one pass over the output instead of two).
  ag::Tensor forward_activated(const ag::Tensor& x, Activation activation);

  std::int64_t members() const { return members_; }
  std::int64_t in_features() const { return in_; }
  std::int64_t out_features() const { return out_; }
  bool has_bias() const { return has_bias_; }
  const ag::Tensor& weight() const { return parameter_at(weight_); }
  const ag::Tensor& bias() const;  // throws when built without bias

  void reset_parameters(ag::Generator& gen);

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ParallelLinear>(*this); }

 private:
  std::int64_t members_;
  std::int64_t in_;
  std::int64_t out_;
  bool has_bias_;
  std::size_t weight_ = 0;
  std::size_t bias_ = 0;
};

}  // namespace maps::nn
