// Layer ops: linear and parallel_linear, each one GEMM per layer with the bias and the activation in the same pass.
#include <algorithm>
#include <stdexcept>
#include <string>

#include "autograd/gemm_kernel.h"
#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/layer_kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

using detail::affine_block;
using detail::column_sums;
using detail::kRowBlock;

// The gradient at the activation's input, from the gradient at the op's output.
Tensor before_activation(const Tensor& g, Fused activation, Node& self) {
  return activation == Fused::Tanh ? tanh_backward(g, self.output()) : g;
}

// parallel_linear's gradients without recording (grad mode off: not create_graph), one layer at a time and within
// it blocks of rows while each block's gradient is in cache: the gradient before the activation (in a per-thread
// scratch block), the bias's and the weight's sums over the blocks, and the input's rows. The threads share out the
// layers. Not for a shared input's gradient (a sum over layers): the caller uses ops there.
Grads parallel_linear_gradients(const Tensor& g, const Tensor& output, const Tensor& x, const Tensor& weight,
                                bool has_bias, bool shared, Fused activation, const Needs& need) {
  const std::int64_t M = weight.size(0), in = weight.size(1), cols = weight.size(2), rows = g.size(1);
  Grads grads(has_bias ? 3 : 2);
  if (need[0]) grads[0] = empty({M, rows, in}, x.dtype());
  // Written by the first block of rows: without rows, nothing writes them.
  if (need[1]) grads[1] = rows == 0 ? zeros(weight.shape(), weight.dtype()) : empty(weight.shape(), weight.dtype());
  if (has_bias && need[2]) grads[2] = empty({M, 1, cols}, weight.dtype());
  dispatch_dtype(g.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using detail::MatrixRef;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    const std::int64_t grain = M * rows * cols * in < detail::kParallelGemmWork ? M : 1;
    parallel_for(M, grain, [&](std::int64_t m0, std::int64_t m1) {
      RowMatrix<T> scratch(std::min(kRowBlock, rows), cols);
      Array block_sums(cols);
      for (std::int64_t m = m0; m < m1; ++m) {
        T* bias_grad = grads.size() > 2 && grads[2].defined() ? grads[2].data<T>() + m * cols : nullptr;
        if (bias_grad != nullptr) Eigen::Map<Array>(bias_grad, cols).setZero();
        for (std::int64_t r0 = 0; r0 < rows; r0 += kRowBlock) {
          const std::int64_t r1 = std::min(rows, r0 + kRowBlock), count = (r1 - r0) * cols;
          const std::int64_t offset = m * rows * cols + r0 * cols;
          const T* gz = g.data<T>() + offset;
          if (activation == Fused::Tanh) {
            const Eigen::Map<const Array> y(output.data<T>() + offset, count);
            Eigen::Map<Array>(scratch.data(), count) = Eigen::Map<const Array>(gz, count) * (T(1) - y * y);
            gz = scratch.data();
          }
          const MatrixRef<const T> gz_block{gz, r1 - r0, cols, cols};
          if (bias_grad != nullptr) {
            column_sums<T>(gz, r1 - r0, cols, block_sums.data());
            Eigen::Map<Array>(bias_grad, cols) += block_sums;
          }
          if (grads[1].defined())
            detail::gemm_serial<T>({x.data<T>() + (shared ? 0 : m * rows * in) + r0 * in, r1 - r0, in, in}, true,
                                   gz_block, false, {grads[1].data<T>() + m * in * cols, in, cols, cols}, r0 > 0);
          if (grads[0].defined())
            detail::gemm_serial<T>(gz_block, false, {weight.data<T>() + m * in * cols, in, cols, cols}, true,
                                   {grads[0].data<T>() + m * rows * in + r0 * in, r1 - r0, in, in}, false);
        }
      }
    });
  });
  return grads;
}

// linear's gradients without recording (grad mode off), in blocks of rows while each block's gradient is in cache:
// the gradient before the activation (in a per-thread scratch block, never written out whole), the input's rows,
// and each thread's sums for the weight and the bias, added up at the end. g [rows, out], x [rows, in].
Grads linear_gradients(const Tensor& g, const Tensor& output, const Tensor& x, const Tensor& weight, bool has_bias,
                       Fused activation, const Needs& need) {
  const std::int64_t rows = g.size(0), cols = weight.size(0), in = weight.size(1);
  Grads grads(has_bias ? 3 : 2);
  if (need[0]) grads[0] = empty({rows, in}, x.dtype());
  const bool want_weight = need[1], want_bias = has_bias && need[2];
  dispatch_dtype(g.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using detail::MatrixRef;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    using Matrix = RowMatrix<T>;
    const std::int64_t units = (rows + 15) / 16;
    const std::int64_t ranges =
        std::max<std::int64_t>(1, parallel_ranges(units, rows * cols * in < detail::kParallelGemmWork ? units : 1));
    // One weight and bias sum per range (all zero when there are no rows), added up in range order.
    std::vector<Matrix> weight_sums(static_cast<std::size_t>(ranges), Matrix::Zero(want_weight ? cols : 0, in));
    std::vector<Array> bias_sums(static_cast<std::size_t>(ranges), Array::Zero(want_bias ? cols : 0));
    parallel_for_ranges(units, ranges, [&](std::int64_t r, std::int64_t u0, std::int64_t u1) {
      const std::size_t range = static_cast<std::size_t>(r);
      Matrix scratch(std::min(kRowBlock, rows), cols);
      for (std::int64_t r0 = u0 * 16, last = std::min(rows, u1 * 16); r0 < last; r0 += kRowBlock) {
        const std::int64_t r1 = std::min(last, r0 + kRowBlock), count = (r1 - r0) * cols;
        const T* gz = g.data<T>() + r0 * cols;
        if (activation == Fused::Tanh) {
          const Eigen::Map<const Array> y(output.data<T>() + r0 * cols, count);
          Eigen::Map<Array>(scratch.data(), count) = Eigen::Map<const Array>(gz, count) * (T(1) - y * y);
          gz = scratch.data();
        }
        const MatrixRef<const T> gz_block{gz, r1 - r0, cols, cols};
        if (want_bias) {
          Array block_sums(cols);
          column_sums<T>(gz, r1 - r0, cols, block_sums.data());
          bias_sums[range] += block_sums;
        }
        if (want_weight)
          detail::gemm_serial<T>(gz_block, true, {x.data<T>() + r0 * in, r1 - r0, in, in}, false,
                                 {weight_sums[range].data(), cols, in, in}, true);
        if (grads[0].defined())
          detail::gemm_serial<T>(gz_block, false, {weight.data<T>(), cols, in, in}, false,
                                 {grads[0].data<T>() + r0 * in, r1 - r0, in, in}, false);
      }
    });
    if (want_weight) {
      grads[1] = empty(weight.shape(), weight.dtype());
      Eigen::Map<Matrix> total(grads[1].data<T>(), cols, in);
      total = weight_sums[0];
      for (std::size_t r = 1; r < weight_sums.size(); ++r) total += weight_sums[r];
    }
    if (want_bias) {
      grads[2] = empty({cols}, weight.dtype());
      Eigen::Map<Array> total(grads[2].data<T>(), cols);
      total = bias_sums[0];
      for (std::size_t r = 1; r < bias_sums.size(); ++r) total += bias_sums[r];
    }
  });
  return grads;
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
  const std::int64_t rows = x2.size(0), in = weight.size(1), cols = weight.size(0);
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const T* px = x2.data<T>();
    const T* pb = bias.defined() ? bias.data<T>() : nullptr;
    const detail::MatrixRef<const T> w{weight.data<T>(), cols, in, in};
    T* po = out.data<T>();
    // Rows in blocks of 16; one block per thread unless the product is small.
    const std::int64_t units = (rows + 15) / 16;
    const std::int64_t grain = rows * cols * in < detail::kParallelGemmWork ? units : 1;
    parallel_for(units, grain, [&](std::int64_t u0, std::int64_t u1) {
      const std::int64_t first = u0 * 16, last = std::min(rows, u1 * 16);
      for (std::int64_t r0 = first; r0 < last; r0 += kRowBlock) {
        const std::int64_t r1 = std::min(last, r0 + kRowBlock);
        affine_block<T>({px + r0 * in, r1 - r0, in, in}, w, true, pb, activation, po + r0 * cols, r1 - r0, cols);
      }
    });
  });
  std::vector<Tensor> inputs{x, weight};
  if (bias.defined()) inputs.push_back(bias);
  return record(
      activation == Fused::Tanh ? "linear_tanh" : "linear", out, inputs,
      [x2, weight, has_bias = bias.defined(), in_shape = x.shape(), activation](const Tensor& g, const Needs& need,
                                                                                Node& self) {
        if (!GradMode::is_enabled()) {
          Grads grads = linear_gradients(g.dim() == 2 ? g : reshape(g, {-1, g.size(-1)}),
                                         activation == Fused::Tanh ? self.output() : Tensor(), x2, weight, has_bias,
                                         activation, need);
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
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const T* px = x.data<T>();
    const T* pw = weight.data<T>();
    const T* pb = bias.defined() ? bias.data<T>() : nullptr;
    T* po = out.data<T>();
    const std::int64_t grain = M * rows * cols * in < detail::kParallelGemmWork ? M : 1;
    parallel_for(M, grain, [&](std::int64_t m0, std::int64_t m1) {
      for (std::int64_t m = m0; m < m1; ++m) {
        for (std::int64_t r0 = 0; r0 < rows; r0 += kRowBlock) {
          const std::int64_t r1 = std::min(rows, r0 + kRowBlock);
          affine_block<T>({px + (shared ? 0 : m * rows * in) + r0 * in, r1 - r0, in, in},
                          {pw + m * in * cols, in, cols, cols}, false, pb == nullptr ? nullptr : pb + m * cols,
                          activation, po + m * rows * cols + r0 * cols, r1 - r0, cols);
        }
      }
    });
  });
  std::vector<Tensor> inputs{x, weight};
  if (bias.defined()) inputs.push_back(bias);
  return record(
      activation == Fused::Tanh ? "parallel_linear_tanh" : "parallel_linear", out, inputs,
      [x, weight, has_bias = bias.defined(), shared, activation](const Tensor& g, const Needs& need, Node& self) {
        if (!GradMode::is_enabled() && !(shared && need[0]))
          return parallel_linear_gradients(g, activation == Fused::Tanh ? self.output() : Tensor(), x, weight, has_bias,
                                           shared, activation, need);
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
