// softmax and log_softmax over one dim, computed stably (shifted by the max).
#include <cmath>

#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

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

}  // namespace

Tensor softmax(const Tensor& x, std::int64_t dim) {
  detail::check_defined(x, "softmax", "input");
  const std::int64_t d = normalize_dim(dim, x.dim(), "softmax");
  Tensor out = softmax_kernel(x, d, false, "softmax");
  return record(
      "softmax", out, {x},
      [d](const Tensor& g, const Needs&, Node& self) {
        const Tensor y = self.output();
        return Grads{mul(y, sub(g, sum(mul(g, y), {d}, true)))};
      },
      true);
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
      true);
}

}  // namespace maps::ag
