// softmax and log_softmax over one dim, computed stably (shifted by the max).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

// x = exp(x) for n values, each the same whatever its neighbours and address: Eigen's vector exp on an aligned,
// zero-padded copy (on the values in place, Eigen would run the unaligned head and the tail through std::exp,
// 1 ulp apart, so a value's bits would depend on where a thread's range starts). The vector exp clamps its input
// near the float range's end (exp(-inf) would be 2.9e-39, not 0): values that far down take std::exp.
template <typename T>
void exp_rows(T* x, std::int64_t n) {
  constexpr std::int64_t kPad = 64 / sizeof(T);  // a multiple of every packet size
  constexpr T kLowest = std::is_same_v<T, float> ? T(-80) : T(-700);
  thread_local std::vector<T, Eigen::aligned_allocator<T>> scratch;
  const std::int64_t padded = (n + kPad - 1) / kPad * kPad;
  scratch.assign(static_cast<std::size_t>(padded), T(0));
  std::copy(x, x + n, scratch.begin());
  Eigen::Map<Eigen::Array<T, Eigen::Dynamic, 1>, Eigen::AlignedMax> values(scratch.data(), padded);
  values = values.exp();
  for (std::int64_t i = 0; i < n; ++i) x[i] = x[i] < kLowest ? std::exp(x[i]) : scratch[static_cast<std::size_t>(i)];
}

// For each [outer, size, inner] slice along the dim: shifted = x - max; out = shifted - log(sum(exp(shifted)))
// for log_softmax, or exp(shifted) / sum(exp(shifted)) for softmax.
Tensor softmax_kernel(const Tensor& x, std::int64_t d, bool log_space, const char* op) {
  detail::check_defined(x, op, "input");
  const detail::DimSplit s = detail::split_at(x.shape(), d);
  Tensor out = empty(x.shape(), x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Mat = Eigen::Array<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    if (s.size == 0) return;
    if (s.inner == 1) {
      // Along the last dim (MAPS's scores: thousands of rows of M = 10), the threads sharing out the rows: each
      // range shifted by its rows' maxima, then exp over the whole range at once in Eigen's vector exp (std::exp
      // per element took 3% of a training step), then each row normalised.
      const T* px = x.data<T>();
      T* po = out.data<T>();
      const std::int64_t width = s.size;
      parallel_for(s.outer, std::max<std::int64_t>(1, detail::kElementwiseGrain / width),
                   [&](std::int64_t r0, std::int64_t r1) {
                     for (std::int64_t row = r0; row < r1; ++row) {
                       const T* in = px + row * width;
                       T* o = po + row * width;
                       const T max = *std::max_element(in, in + width);
                       for (std::int64_t i = 0; i < width; ++i) o[i] = in[i] - max;
                     }
                     if (!log_space) {
                       exp_rows(po + r0 * width, (r1 - r0) * width);
                       for (std::int64_t row = r0; row < r1; ++row) {
                         T* o = po + row * width;
                         T total = 0;
                         for (std::int64_t i = 0; i < width; ++i) total += o[i];
                         const T inverse = T(1) / total;
                         for (std::int64_t i = 0; i < width; ++i) o[i] *= inverse;
                       }
                       return;
                     }
                     for (std::int64_t row = r0; row < r1; ++row) {
                       T* o = po + row * width;
                       T total = 0;
                       for (std::int64_t i = 0; i < width; ++i) total += std::exp(o[i]);
                       const T log_total = std::log(total);
                       for (std::int64_t i = 0; i < width; ++i) o[i] -= log_total;
                     }
                   });
      return;
    }
    for (std::int64_t o = 0; o < s.outer; ++o) {
      // Rows of m are positions along the dim; columns are the independent inner slices.
      Eigen::Map<const Mat> m(x.data<T>() + o * s.size * s.inner, s.size, s.inner);
      Eigen::Map<Mat> r(out.data<T>() + o * s.size * s.inner, s.size, s.inner);
      const Eigen::Array<T, 1, Eigen::Dynamic> max = m.colwise().maxCoeff();
      r = m.rowwise() - max;
      if (log_space) {
        const Eigen::Array<T, 1, Eigen::Dynamic> log_total = r.exp().colwise().sum().log();
        r.rowwise() -= log_total;
      } else {
        r = r.exp();
        const Eigen::Array<T, 1, Eigen::Dynamic> total = r.colwise().sum();
        r.rowwise() /= total;
      }
    }
  });
  return out;
}

// y (g - sum(g y)) along the last dim in one pass, not recorded (the backward of softmax without create_graph).
Tensor softmax_backward_last_dim(const Tensor& g, const Tensor& y) {
  Tensor out = empty(y.shape(), y.dtype());
  const std::int64_t width = y.size(-1), rows = width == 0 ? 0 : y.numel() / width;
  dispatch_dtype(y.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const T* pg = g.data<T>();
    const T* py = y.data<T>();
    T* po = out.data<T>();
    parallel_for(rows, std::max<std::int64_t>(1, detail::kElementwiseGrain / std::max<std::int64_t>(width, 1)),
                 [&](std::int64_t r0, std::int64_t r1) {
                   for (std::int64_t row = r0; row < r1; ++row) {
                     const T* gr = pg + row * width;
                     const T* yr = py + row * width;
                     T dot = 0;
                     for (std::int64_t i = 0; i < width; ++i) dot += gr[i] * yr[i];
                     for (std::int64_t i = 0; i < width; ++i) po[row * width + i] = yr[i] * (gr[i] - dot);
                   }
                 });
  });
  return out;
}

}  // namespace

Tensor softmax(const Tensor& x, std::int64_t dim) {
  detail::check_defined(x, "softmax", "input");
  const std::int64_t d = normalize_dim(dim, x.dim(), "softmax");
  Tensor out = softmax_kernel(x, d, false, "softmax");
  return record(
      "softmax", out, {x},
      [d](const Tensor& g, const Needs&, Node& self) {
        const Tensor y = self.output();
        if (!GradMode::is_enabled() && d == y.dim() - 1) return Grads{softmax_backward_last_dim(g, y)};
        return Grads{mul(y, sub(g, sum(mul(g, y), {d}, true)))};
      },
      true, Reads::none());
}

Tensor log_softmax(const Tensor& x, std::int64_t dim) {
  detail::check_defined(x, "log_softmax", "input");
  const std::int64_t d = normalize_dim(dim, x.dim(), "log_softmax");
  Tensor out = softmax_kernel(x, d, true, "log_softmax");
  return record(
      "log_softmax", out, {x},
      [d](const Tensor& g, const Needs&, Node& self) {
        return Grads{sub(g, mul(exp(self.output()), sum(g, {d}, true)))};
      },
      true, Reads::none());
}

}  // namespace maps::ag
