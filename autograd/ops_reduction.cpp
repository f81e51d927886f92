// Reductions over all elements or over chosen dims: sum, mean, amax.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

enum class Reduce { Sum, Max };

std::vector<std::int64_t> normalize_dims(const Tensor& x, const std::vector<std::int64_t>& dims, const char* op) {
  if (dims.empty())
    throw std::invalid_argument(std::string(op) + ": no dims were given (reduce over all with " + op + "(x))");
  std::vector<std::int64_t> out;
  for (std::int64_t dim : dims) {
    const std::int64_t d = normalize_dim(dim, x.dim(), op);
    if (std::find(out.begin(), out.end(), d) != out.end()) {
      throw std::invalid_argument(std::string(op) + ": dim " + std::to_string(dim) + " is given twice");
    }
    out.push_back(d);
  }
  return out;
}

Shape keepdim_shape(const Shape& shape, const std::vector<std::int64_t>& dims) {
  Shape out = shape;
  for (std::int64_t d : dims) out[d] = 1;
  return out;
}

Shape reduced_shape(const Shape& shape, const std::vector<std::int64_t>& dims, bool keepdim) {
  if (keepdim) return keepdim_shape(shape, dims);
  Shape out;
  for (std::size_t i = 0; i < shape.size(); ++i) {
    if (std::find(dims.begin(), dims.end(), static_cast<std::int64_t>(i)) == dims.end()) out.push_back(shape[i]);
  }
  return out;
}

// Eigen's maxCoeff may skip a NaN depending on where it sits; torch.amax returns NaN for any
// slice holding one, so such slices are set to NaN afterwards.
void propagate_nan_max(const Tensor& x, const detail::DimSplit& s, Tensor& out) {
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    if (!x.array<T>().isNaN().any()) return;
    const T* src = x.data<T>();
    T* dst = out.data<T>();
    for (std::int64_t o = 0; o < s.outer; ++o) {
      for (std::int64_t r = 0; r < s.size; ++r) {
        for (std::int64_t i = 0; i < s.inner; ++i) {
          if (std::isnan(src[(o * s.size + r) * s.inner + i]))
            dst[o * s.inner + i] = src[(o * s.size + r) * s.inner + i];
        }
      }
    }
  });
}

// Reduces one dim, keeping it with size 1.
Tensor reduce_one_dim(const Tensor& x, std::int64_t d, Reduce kind, const char* op) {
  const detail::DimSplit s = detail::split_at(x.shape(), d);
  if (s.size == 0 && kind == Reduce::Max) {
    throw std::invalid_argument(std::string(op) + ": cannot take the max over an empty dim of " + to_string(x.shape()));
  }
  Shape out_shape = x.shape();
  out_shape[d] = 1;
  Tensor out = empty(out_shape, x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Mat = RowMatrix<T>;
    const T* src = x.data<T>();
    T* dst = out.data<T>();
    if (s.inner == 1) {
      Eigen::Map<const Mat> m(src, s.outer, s.size);
      Eigen::Map<Eigen::Matrix<T, Eigen::Dynamic, 1>> o(dst, s.outer);
      if (kind == Reduce::Sum) {
        o = m.rowwise().sum();
      } else {
        o = m.rowwise().maxCoeff();
      }
      return;
    }
    for (std::int64_t i = 0; i < s.outer; ++i) {
      Eigen::Map<const Mat> m(src + i * s.size * s.inner, s.size, s.inner);
      Eigen::Map<Eigen::Matrix<T, 1, Eigen::Dynamic>> o(dst + i * s.inner, s.inner);
      if (kind == Reduce::Sum) {
        o = m.colwise().sum();
      } else {
        o = m.colwise().maxCoeff();
      }
    }
  });
  if (kind == Reduce::Max) propagate_nan_max(x, s, out);
  return out;
}

Tensor reduce_dims(const Tensor& x, const std::vector<std::int64_t>& dims, Reduce kind, const char* op) {
  Tensor cur = x;
  for (std::int64_t d : dims) cur = reduce_one_dim(cur, d, kind, op);
  return cur;
}

std::vector<std::int64_t> all_dims(const Tensor& x) {
  std::vector<std::int64_t> dims(x.dim());
  for (std::int64_t i = 0; i < x.dim(); ++i) dims[i] = i;
  return dims;
}

}  // namespace

Tensor sum(const Tensor& x, const std::vector<std::int64_t>& dims, bool keepdim) {
  detail::check_defined(x, "sum", "input");
  const std::vector<std::int64_t> ds = normalize_dims(x, dims, "sum");
  Tensor reduced;
  {
    NoGradGuard no_grad;
    reduced = reduce_dims(x, ds, Reduce::Sum, "sum").reshape(reduced_shape(x.shape(), ds, keepdim));
  }
  Tensor out = reduced.detach();
  return record(
      "sum", out, {x},
      [shape = x.shape(), kept = keepdim_shape(x.shape(), ds)](const Tensor& g, const Needs&, Node&) {
        return Grads{expand(reshape(g, kept), shape)};
      },
      false, Reads::none());
}

Tensor sum(const Tensor& x) {
  detail::check_defined(x, "sum", "input");
  Tensor out = empty({}, x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    out.data<T>()[0] = x.array<T>().sum();
  });
  return record(
      "sum", out, {x}, [shape = x.shape()](const Tensor& g, const Needs&, Node&) { return Grads{expand(g, shape)}; },
      false, Reads::none());
}

Tensor mean(const Tensor& x, const std::vector<std::int64_t>& dims, bool keepdim) {
  detail::check_defined(x, "mean", "input");
  const std::vector<std::int64_t> ds = normalize_dims(x, dims, "mean");
  std::int64_t count = 1;
  for (std::int64_t d : ds) count *= x.shape()[d];
  if (count == 0) throw std::invalid_argument("mean: the reduced dims of " + to_string(x.shape()) + " are empty");
  return mul(sum(x, ds, keepdim), 1.0 / static_cast<double>(count));
}

Tensor mean(const Tensor& x) {
  detail::check_defined(x, "mean", "input");
  if (x.numel() == 0) throw std::invalid_argument("mean: the tensor of shape " + to_string(x.shape()) + " is empty");
  return mul(sum(x), 1.0 / static_cast<double>(x.numel()));
}

Tensor amax(const Tensor& x, const std::vector<std::int64_t>& dims, bool keepdim) {
  detail::check_defined(x, "amax", "input");
  const std::vector<std::int64_t> ds = normalize_dims(x, dims, "amax");
  const Shape kept = keepdim_shape(x.shape(), ds);
  Tensor out;
  {
    NoGradGuard no_grad;
    out = reduce_dims(x, ds, Reduce::Max, "amax").reshape(reduced_shape(x.shape(), ds, keepdim)).detach();
  }
  return record(
      "amax", out, {x},
      [x, ds, kept](const Tensor& g, const Needs&, Node& self) {
        // Ties share the gradient: weight = [x == max] / (number of maxima in the reduced block).
        Tensor weight;
        {
          NoGradGuard no_grad;
          Tensor is_max = eq(x, expand(reshape(self.output(), kept), x.shape()));
          weight = div(is_max, expand(sum(is_max, ds, true), x.shape()));
        }
        return Grads{mul(expand(reshape(g, kept), x.shape()), weight)};
      },
      /*save_output=*/true);
}

Tensor amax(const Tensor& x) {
  detail::check_defined(x, "amax", "input");
  if (x.numel() == 0) throw std::invalid_argument("amax: the tensor of shape " + to_string(x.shape()) + " is empty");
  if (x.dim() == 0) return amax(reshape(x, {1}), {0}, false);
  return amax(x, all_dims(x), false);
}

}  // namespace maps::ag
