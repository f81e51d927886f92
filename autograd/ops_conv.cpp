// The 1-D convolution and its two adjoints as ops of their own, each one GEMM over the batch's windows (im2col):
// built from narrow, stack and transpose instead, Diffusion Policy's U-Net spent three quarters of a training step
// copying small slices (issue 46). The three are closed under differentiation, each one's rule written in the
// others, so second-order gradients (create_graph) come for free.
#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "autograd/gemm_kernel.h"
#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

// x [batch, in, length] against a kernel of `kernel` taps, `padding` zeros at both ends -> [batch, out, out_length].
struct ConvShape {
  std::int64_t batch, in, length, out, kernel, padding, out_length;
  std::int64_t rows() const { return batch * out_length; }  // one window per output position
  std::int64_t taps() const { return in * kernel; }         // a window's values, channel-major like the weight
};

// Output positions [first, last) whose whole window lies inside x (no padding read): windows copy or add in one
// run there, and only the few positions at the ends test each tap.
std::pair<std::int64_t, std::int64_t> inner_positions(const ConvShape& s) {
  const std::int64_t first = std::min(s.padding, s.out_length);
  const std::int64_t last = std::max(first, std::min(s.out_length, s.length + s.padding - s.kernel + 1));
  return {first, last};
}

// cols [batch * out_length, in * kernel]: row (b, t) holds x[b, c, t + k - padding] at column c * kernel + k.
template <typename T>
void im2col(const T* x, const ConvShape& s, T* cols) {
  // Plain variables, not structured bindings: clang 14 cannot capture those in the lambdas below.
  const std::pair<std::int64_t, std::int64_t> inner = inner_positions(s);
  const std::int64_t first = inner.first, last = inner.second;
  parallel_for(s.batch, 1, [&](std::int64_t b0, std::int64_t b1) {
    for (std::int64_t b = b0; b < b1; ++b)
      for (std::int64_t t = 0; t < s.out_length; ++t) {
        T* row = cols + (b * s.out_length + t) * s.taps();
        const T* sample = x + b * s.in * s.length;
        if (t >= first && t < last) {
          // A loop, not std::copy_n: a kernel's few values are not worth a call to memmove.
          for (std::int64_t c = 0; c < s.in; ++c) {
            const T* from = sample + c * s.length + (t - s.padding);  // t >= padding here: never before x
            for (std::int64_t k = 0; k < s.kernel; ++k) row[c * s.kernel + k] = from[k];
          }
          continue;
        }
        for (std::int64_t c = 0; c < s.in; ++c)
          for (std::int64_t k = 0; k < s.kernel; ++k) {
            const std::int64_t at = t + k - s.padding;
            row[c * s.kernel + k] = at >= 0 && at < s.length ? sample[c * s.length + at] : T(0);
          }
      }
  });
}

// The adjoint of im2col: every window value added back to its place in x [batch, in, length] (x is overwritten).
template <typename T>
void col2im(const T* cols, const ConvShape& s, T* x) {
  // Plain variables, not structured bindings: clang 14 cannot capture those in the lambdas below.
  const std::pair<std::int64_t, std::int64_t> inner = inner_positions(s);
  const std::int64_t first = inner.first, last = inner.second;
  parallel_for(s.batch, 1, [&](std::int64_t b0, std::int64_t b1) {
    for (std::int64_t b = b0; b < b1; ++b) {
      std::fill(x + b * s.in * s.length, x + (b + 1) * s.in * s.length, T(0));
      for (std::int64_t t = 0; t < s.out_length; ++t) {
        const T* row = cols + (b * s.out_length + t) * s.taps();
        T* sample = x + b * s.in * s.length;
        const bool whole_window = t >= first && t < last;
        for (std::int64_t c = 0; c < s.in; ++c)
          for (std::int64_t k = 0; k < s.kernel; ++k) {
            const std::int64_t at = t + k - s.padding;
            if (whole_window || (at >= 0 && at < s.length)) sample[c * s.length + at] += row[c * s.kernel + k];
          }
      }
    }
  });
}

// Each of `batch` row-major [rows, cols] blocks of src transposed into dst: y [batch, channels, positions] to rows
// [batch * positions, channels] with (channels, positions), and back with (positions, channels).
template <typename T>
void transpose_each(const T* src, std::int64_t batch, std::int64_t rows, std::int64_t cols, T* dst) {
  using Mat = RowMatrix<T>;
  parallel_for(batch, 1, [&](std::int64_t b0, std::int64_t b1) {
    for (std::int64_t b = b0; b < b1; ++b)
      Eigen::Map<Mat>(dst + b * rows * cols, cols, rows) =
          Eigen::Map<const Mat>(src + b * rows * cols, rows, cols).transpose();
  });
}

void check_padding(std::int64_t padding, const char* op) {
  if (padding < 0)
    throw std::invalid_argument(std::string(op) + ": padding must be >= 0, got " + std::to_string(padding));
}

std::int64_t output_length(std::int64_t length, std::int64_t kernel, std::int64_t padding, const char* op) {
  const std::int64_t out_length = length + 2 * padding - kernel + 1;
  if (out_length < 1)
    throw std::invalid_argument(std::string(op) + ": a kernel of " + std::to_string(kernel) +
                                " is longer than the padded length " + std::to_string(length + 2 * padding));
  return out_length;
}

// conv1d_weight_grad's values: [out, in * kernel] = rows^T cols, summed over every window of the batch; `cols` is
// x's windows when the caller has them (conv1d's own backward), else undefined and made here.
Tensor weight_gradient(const Tensor& x, const Tensor& grad_output, const ConvShape& s, Tensor cols) {
  Tensor out = empty({s.out, s.in, s.kernel}, x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using detail::MatrixRef;
    Tensor rows = empty({s.rows(), s.out}, x.dtype());
    transpose_each(grad_output.data<T>(), s.batch, s.out, s.out_length, rows.data<T>());
    if (!cols.defined()) {
      cols = empty({s.rows(), s.taps()}, x.dtype());
      im2col(x.data<T>(), s, cols.data<T>());
    }
    detail::gemm_parallel(MatrixRef<const T>{rows.data<T>(), s.rows(), s.out, s.out}, true,
                          MatrixRef<const T>{cols.data<T>(), s.rows(), s.taps(), s.taps()}, false,
                          MatrixRef<T>{out.data<T>(), s.out, s.taps(), s.taps()}, false);
  });
  return out;
}

}  // namespace

Tensor conv1d(const Tensor& x, const Tensor& weight, const Tensor& bias, std::int64_t padding) {
  detail::check_1d_layout(x, "conv1d", "x");
  detail::check_defined(weight, "conv1d", "weight");
  if (weight.dim() != 3 || weight.size(1) != x.size(1) || weight.size(2) < 1)
    throw std::invalid_argument("conv1d: expected weight of shape [out, " + std::to_string(x.size(1)) +
                                ", kernel] for x of shape " + to_string(x.shape()) + ", got " +
                                to_string(weight.shape()));
  detail::check_same_dtype(weight, "weight", x, "x", "conv1d");
  if (bias.defined()) {
    if (bias.shape() != Shape{weight.size(0)})
      throw std::invalid_argument("conv1d: expected bias of shape [" + std::to_string(weight.size(0)) + "], got " +
                                  to_string(bias.shape()));
    detail::check_same_dtype(bias, "bias", x, "x", "conv1d");
  }
  check_padding(padding, "conv1d");
  const ConvShape s{x.size(0),
                    x.size(1),
                    x.size(2),
                    weight.size(0),
                    weight.size(2),
                    padding,
                    output_length(x.size(2), weight.size(2), padding, "conv1d")};
  Tensor out = empty({s.batch, s.out, s.out_length}, x.dtype());
  Tensor cols = empty({s.rows(), s.taps()}, x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using detail::MatrixRef;
    Tensor rows = empty({s.rows(), s.out}, x.dtype());
    im2col(x.data<T>(), s, cols.data<T>());
    // rows = cols W^T, the weight read in place as [out, in * kernel].
    detail::gemm_parallel(MatrixRef<const T>{cols.data<T>(), s.rows(), s.taps(), s.taps()}, false,
                          MatrixRef<const T>{weight.data<T>(), s.out, s.taps(), s.taps()}, true,
                          MatrixRef<T>{rows.data<T>(), s.rows(), s.out, s.out}, false);
    transpose_each(rows.data<T>(), s.batch, s.out_length, s.out, out.data<T>());
    if (bias.defined()) {
      const T* b = bias.data<T>();
      T* y = out.data<T>();
      for (std::int64_t i = 0; i < s.batch * s.out; ++i)
        Eigen::Map<Eigen::Array<T, Eigen::Dynamic, 1>>(y + i * s.out_length, s.out_length) += b[i % s.out];
    }
  });
  std::vector<Tensor> inputs{x, weight};
  if (bias.defined()) inputs.push_back(bias);
  // The backward keeps the forward's windows for the weight's gradient (a third of the window copies saved), when the
  // weight wants one; under create_graph that gradient is the recorded op instead, made from x.
  if (!weight.requires_grad()) cols = Tensor();
  return record("conv1d", out, inputs, [x, weight, s, cols](const Tensor& g, const Needs& need, Node&) {
    Grads grads(need.size());
    if (need[0]) grads[0] = conv1d_input_grad(g, weight, s.length, s.padding);
    if (need[1])
      grads[1] =
          GradMode::is_enabled() ? conv1d_weight_grad(x, g, s.kernel, s.padding) : weight_gradient(x, g, s, cols);
    if (need.size() > 2 && need[2]) grads[2] = sum(g, {0, 2});
    return grads;
  });
}

Tensor conv1d_input_grad(const Tensor& grad_output, const Tensor& weight, std::int64_t length, std::int64_t padding) {
  const char* op = "conv1d_input_grad";
  detail::check_1d_layout(grad_output, op, "grad_output");
  detail::check_defined(weight, op, "weight");
  detail::check_same_dtype(weight, "weight", grad_output, "grad_output", op);
  check_padding(padding, op);
  if (weight.dim() != 3 || weight.size(0) != grad_output.size(1) || weight.size(2) < 1 || length < 1 ||
      output_length(length, weight.size(2), padding, op) != grad_output.size(2))
    throw std::invalid_argument(std::string(op) + ": grad_output " + to_string(grad_output.shape()) +
                                " is not the output of weight " + to_string(weight.shape()) + " on length " +
                                std::to_string(length) + " with padding " + std::to_string(padding));
  const ConvShape s{grad_output.size(0), weight.size(1), length, weight.size(0), weight.size(2), padding,
                    grad_output.size(2)};
  Tensor out = empty({s.batch, s.in, s.length}, grad_output.dtype());
  dispatch_dtype(grad_output.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using detail::MatrixRef;
    Tensor rows = empty({s.rows(), s.out}, grad_output.dtype());
    Tensor cols = empty({s.rows(), s.taps()}, grad_output.dtype());
    transpose_each(grad_output.data<T>(), s.batch, s.out, s.out_length, rows.data<T>());
    detail::gemm_parallel(MatrixRef<const T>{rows.data<T>(), s.rows(), s.out, s.out}, false,
                          MatrixRef<const T>{weight.data<T>(), s.out, s.taps(), s.taps()}, false,
                          MatrixRef<T>{cols.data<T>(), s.rows(), s.taps(), s.taps()}, false);
    col2im(cols.data<T>(), s, out.data<T>());
  });
  return record(op, out, {grad_output, weight},
                [grad_output, weight, padding, kernel = s.kernel](const Tensor& h, const Needs& need, Node&) {
                  Grads grads(2);
                  if (need[0]) grads[0] = conv1d(h, weight, Tensor(), padding);
                  if (need[1]) grads[1] = conv1d_weight_grad(h, grad_output, kernel, padding);
                  return grads;
                });
}

Tensor conv1d_weight_grad(const Tensor& x, const Tensor& grad_output, std::int64_t kernel, std::int64_t padding) {
  const char* op = "conv1d_weight_grad";
  detail::check_1d_layout(x, op, "x");
  detail::check_1d_layout(grad_output, op, "grad_output");
  detail::check_same_dtype(grad_output, "grad_output", x, "x", op);
  check_padding(padding, op);
  if (grad_output.size(0) != x.size(0))
    throw std::invalid_argument(std::string(op) + ": grad_output " + to_string(grad_output.shape()) + " has " +
                                std::to_string(grad_output.size(0)) + " rows, x " + to_string(x.shape()) + " " +
                                std::to_string(x.size(0)));
  if (kernel < 1 || output_length(x.size(2), kernel, padding, op) != grad_output.size(2))
    throw std::invalid_argument(std::string(op) + ": grad_output " + to_string(grad_output.shape()) +
                                " is not the output of a kernel of " + std::to_string(kernel) + " on x " +
                                to_string(x.shape()) + " with padding " + std::to_string(padding));
  const ConvShape s{x.size(0), x.size(1), x.size(2), grad_output.size(1), kernel, padding, grad_output.size(2)};
  const Tensor out = weight_gradient(x, grad_output, s, Tensor());
  return record(op, out, {x, grad_output}, [x, grad_output, padding](const Tensor& h, const Needs& need, Node&) {
    Grads grads(2);
    if (need[0]) grads[0] = conv1d_input_grad(grad_output, h, x.size(2), padding);
    if (need[1]) grads[1] = conv1d(x, h, Tensor(), padding);
    return grads;
  });
}

}  // namespace maps::ag
