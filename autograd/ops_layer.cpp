// Layer ops: linear and parallel_linear, each one GEMM per layer with the bias and the activation in the same pass
// (one layer of the mlp and parallel_mlp kernels).
#include <stdexcept>
#include <string>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/layer_kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

// The gradient at the activation's input, from the gradient at the op's output.
Tensor before_activation(const Tensor& g, Fused activation, Node& self) {
  return activation == Fused::Tanh ? tanh_backward(g, self.output()) : g;
}

}  // namespace

Tensor linear(const Tensor& x, const Tensor& weight, const Tensor& bias, Fused activation) {
  detail::check_defined(x, "linear", "input");
  detail::check_defined(weight, "linear", "weight");
  if (weight.dim() != 2) {
    throw std::invalid_argument("linear: weight must be [out, in], got " + to_string(weight.shape()));
  }
  if (x.dim() < 1 || x.size(-1) != weight.size(1)) {
    throw std::invalid_argument("linear: input of shape " + to_string(x.shape()) + " does not end in in_features " +
                                std::to_string(weight.size(1)) + " of weight " + to_string(weight.shape()));
  }
  if (bias.defined() && bias.shape() != Shape{weight.size(0)}) {
    throw std::invalid_argument("linear: bias of shape " + to_string(bias.shape()) + " does not match weight " +
                                to_string(weight.shape()) + " (expected [" + std::to_string(weight.size(0)) + "])");
  }
  detail::check_same_dtype(x, weight, "linear");
  if (bias.defined()) detail::check_same_dtype(x, bias, "linear");
  Shape out_shape = x.shape();
  out_shape.back() = weight.size(0);
  const Tensor x2 = x.dim() == 2 ? x : reshape(x, {-1, x.size(-1)});
  Tensor out = empty(out_shape, x.dtype());
  // One layer of mlp's kernels (layer_kernels.h).
  const detail::LinearStack stack{x2.size(0), 1, bias.defined(), {weight.size(1), weight.size(0)}, {activation}};
  detail::linear_stack_forward(stack, x2, {weight}, bias.defined() ? std::vector<Tensor>{bias} : std::vector<Tensor>{},
                               {out});
  std::vector<Tensor> inputs{x, weight};
  if (bias.defined()) inputs.push_back(bias);
  return record(
      activation == Fused::Tanh ? "linear_tanh" : "linear", out, inputs,
      [x2, weight, has_bias = bias.defined(), in_shape = x.shape(), activation, stack](const Tensor& g,
                                                                                       const Needs& need, Node& self) {
        if (!GradMode::is_enabled()) {
          Grads grads = detail::linear_stack_gradients(stack, g, x2, {weight},
                                                       {activation == Fused::Tanh ? self.output() : Tensor()}, need);
          if (grads[0].defined()) grads[0] = reshape(grads[0], in_shape);
          return grads;
        }
        const Tensor gz = before_activation(g, activation, self);
        const Tensor g2 = gz.dim() == 2 ? gz : reshape(gz, {-1, gz.size(-1)});
        Grads grads(has_bias ? 3 : 2);
        if (need[0]) grads[0] = reshape(matmul(g2, weight), in_shape);
        if (need[1]) grads[1] = gemm(g2, x2, true, false);
        if (has_bias && need[2]) grads[2] = sum(g2, {0});
        return grads;
      },
      activation != Fused::None);
}

Tensor parallel_linear(const Tensor& x, const Tensor& weight, const Tensor& bias, Fused activation) {
  detail::check_defined(x, "parallel_linear", "input");
  detail::check_defined(weight, "parallel_linear", "weight");
  if (weight.dim() != 3)
    throw std::invalid_argument("parallel_linear: weight must be [members, in, out], got " + to_string(weight.shape()));
  const std::int64_t M = weight.size(0), in = weight.size(1), cols = weight.size(2);
  const bool shared = x.dim() == 2 && x.size(1) == in;
  const bool batched = x.dim() == 3 && x.size(0) == M && x.size(2) == in;
  if (!shared && !batched)
    throw std::invalid_argument("parallel_linear: input of shape " + to_string(x.shape()) + " does not fit weight " +
                                to_string(weight.shape()) + " (expected [" + std::to_string(M) + ", batch, " +
                                std::to_string(in) + "] or [batch, " + std::to_string(in) + "])");
  if (bias.defined() && bias.shape() != Shape{M, 1, cols})
    throw std::invalid_argument("parallel_linear: bias of shape " + to_string(bias.shape()) +
                                " does not match weight " + to_string(weight.shape()) + " (expected [" +
                                std::to_string(M) + ", 1, " + std::to_string(cols) + "])");
  detail::check_same_dtype(x, weight, "parallel_linear");
  if (bias.defined()) detail::check_same_dtype(x, bias, "parallel_linear");
  const std::int64_t rows = x.size(-2);
  Tensor out = empty({M, rows, cols}, x.dtype());
  // One layer of parallel_mlp's kernels (layer_kernels.h).
  const detail::ParallelStack stack{M, rows, 1, shared, bias.defined(), {in, cols}};
  detail::parallel_stack_forward(stack, x, {weight}, bias.defined() ? std::vector<Tensor>{bias} : std::vector<Tensor>{},
                                 activation, {out});
  std::vector<Tensor> inputs{x, weight};
  if (bias.defined()) inputs.push_back(bias);
  return record(
      activation == Fused::Tanh ? "parallel_linear_tanh" : "parallel_linear", out, inputs,
      [x, weight, has_bias = bias.defined(), shared, activation, stack](const Tensor& g, const Needs& need,
                                                                        Node& self) {
        if (!GradMode::is_enabled() && !(shared && need[0]))
          return detail::parallel_stack_gradients(
              stack, g, x, {weight}, {activation == Fused::Tanh ? self.output() : Tensor()}, activation, need);
        const Tensor gz = before_activation(g, activation, self);  // [M, B, out]
        Grads grads(has_bias ? 3 : 2);
        if (need[0]) {
          const Tensor per_member = gemm(gz, weight, false, true);  // [M, B, in]
          grads[0] = shared ? sum(per_member, {0}) : per_member;
        }
        if (need[1]) {
          const Tensor input = shared ? expand(x, {weight.size(0), x.size(0), x.size(1)}) : x;
          grads[1] = gemm(input, gz, true, false);
        }
        if (has_bias && need[2]) grads[2] = sum(gz, {1}, true);
        return grads;
      },
      activation != Fused::None);
}

}  // namespace maps::ag
