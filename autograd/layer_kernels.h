#pragma once

// Kernels shared by the layer ops (ops_layer.cpp, ops_parallel_mlp.cpp). Internal to the autograd layer.

#include <cstdint>

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

}  // namespace maps::ag::detail
