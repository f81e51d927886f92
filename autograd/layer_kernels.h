#pragma once

// Kernels shared by the layer ops (ops_layer.cpp, ops_mlp.cpp, ops_parallel_mlp.cpp): linear is a one-layer mlp and
// parallel_linear a one-layer parallel_mlp, their forward passes and unrecorded gradients the same code. Internal to
// the autograd layer.

#include <cstdint>
#include <vector>

#include "autograd/gemm_kernel.h"
#include "autograd/ops.h"

namespace maps::ag::detail {

// Rows per block of linear's forward and backward: a block's output and gradient stay in L2 between the passes
// over them (a [512, 128] float block is 256 KB).
constexpr std::int64_t kRowBlock = 512;

// Column sums of a contiguous rows x cols matrix into out [cols].
template <typename T>
void column_sums(const T* x, std::int64_t rows, std::int64_t cols, T* out) {
  Eigen::Map<Eigen::Array<T, Eigen::Dynamic, 1>> sums(out, cols);
  sums.setZero();
  for (std::int64_t r = 0; r < rows; ++r)
    sums += Eigen::Map<const Eigen::Array<T, Eigen::Dynamic, 1>>(x + r * cols, cols);
}

// Out (rows x cols, contiguous) = bias in every row (or left for the GEMM to overwrite), then += x W, then the
// activation in place.
template <typename T>
void affine_block(detail::MatrixRef<const T> x, detail::MatrixRef<const T> w, bool transpose_w, const T* bias,
                  Fused activation, T* out, std::int64_t rows, std::int64_t cols) {
  using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
  Eigen::Map<RowMatrix<T>> o(out, rows, cols);
  if (bias != nullptr) o.rowwise() = Eigen::Map<const Eigen::Matrix<T, 1, Eigen::Dynamic>>(bias, cols);
  detail::gemm_serial(x, false, w, transpose_w, detail::MatrixRef<T>{out, rows, cols, cols}, bias != nullptr);
  if (activation == Fused::Tanh) {
    Eigen::Map<Array> a(out, rows * cols);
    a = a.tanh();
  }
}

// A stack of linear layers (weights [out_l, in_l]) on `rows` rows: mlp, and linear as one layer.
struct LinearStack {
  std::int64_t rows = 0, count = 0;
  bool has_bias = false;
  std::vector<std::int64_t> widths;  // in, out_0, ..., out_{L-1}
  std::vector<Fused> activations;    // after each layer
};
// Fills outputs[l] (handles to tensors the caller allocated, [rows, out_l] contiguous) block of rows by block, each
// block through every layer while its activations are in cache; the threads share out the blocks.
void linear_stack_forward(const LinearStack& s, const Tensor& x, const std::vector<Tensor>& weights,
                          const std::vector<Tensor>& biases, std::vector<Tensor> outputs);
// The gradients from the outputs without recording (grad mode off), block of rows by block: the gradient flows down
// the layers through two scratch blocks that stay in cache; each range of rows sums its own weight and bias
// gradients, added up in range order. `outputs` needs the layers that have tanh and those whose output is the next
// one's input. Gradients are ordered x, w_0, [b_0], w_1, ...
std::vector<Tensor> linear_stack_gradients(const LinearStack& s, const Tensor& g, const Tensor& x,
                                           const std::vector<Tensor>& weights, const std::vector<Tensor>& outputs,
                                           const std::vector<bool>& need);

// A stack of parallel layers (weights [M, in_l, out_l]) with one activation after each: parallel_mlp, and
// parallel_linear as one layer. `shared`: the input is [rows, in] for every member, else [M, rows, in].
struct ParallelStack {
  std::int64_t members = 0, rows = 0, layers = 0;
  bool shared = false, has_bias = false;
  std::vector<std::int64_t> widths;  // in, out_0, ..., out_{L-1}
};
// Fills outputs[l] ([M, rows, out_l], allocated by the caller) member by member, each member's whole stack while
// its activations are in cache; the threads share out the members.
void parallel_stack_forward(const ParallelStack& s, const Tensor& x, const std::vector<Tensor>& weights,
                            const std::vector<Tensor>& biases, Fused activation, std::vector<Tensor> outputs);
// The gradients from the outputs without recording, member by member through two scratch blocks; not for a shared
// input's gradient (a sum over members: the callers use ops there). Ordered as linear_stack_gradients.
std::vector<Tensor> parallel_stack_gradients(const ParallelStack& s, const Tensor& g, const Tensor& x,
                                             const std::vector<Tensor>& weights, const std::vector<Tensor>& outputs,
                                             Fused activation, const std::vector<bool>& need);

}  // namespace maps::ag::detail
