// Gram-Schmidt orthonormalisation of each sample's k vectors (MOORE's orthogonal layer), as one op: a kernel forward
// and a backward written in ops, so that it is differentiable twice.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"
#include "autograd/parallel.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

// A [k, k] mask of ones where keep(row, column), in the dtype of the tensors it multiplies.
Tensor triangle_mask(std::int64_t k, Dtype dtype, bool (*keep)(std::int64_t, std::int64_t)) {
  std::vector<double> values(static_cast<std::size_t>(k * k), 0.0);
  for (std::int64_t r = 0; r < k; ++r)
    for (std::int64_t c = 0; c < k; ++c) values[static_cast<std::size_t>(r * k + c)] = keep(r, c) ? 1.0 : 0.0;
  return from_vector(values, {k, k}, dtype);
}

// The gradient of v from the gradient g of u = gram_schmidt(v). Per sample, with the k vectors as rows, v = R^T u
// where R [k, k] is upper triangular, R_ji = <u_j, v_i> (the thin QR of [v_1 ... v_k]). Then
//   v_bar = R^{-1} (g - S u),  S = copyltu(g u^T) (lower triangle, copied to the upper),
// solved by back substitution on R's rows. Every step is an op, so the rule is differentiable again.
Tensor gram_schmidt_backward(const Tensor& g, const Tensor& u, const Tensor& v) {
  const std::int64_t k = u.size(0);
  const Tensor ut = transpose(u, 0, 1), gt = transpose(g, 0, 1), vt = transpose(v, 0, 1);  // [n, k, F]
  const Tensor p = gemm(gt, ut, false, true);                                              // [n, k, k]
  const Tensor lower = triangle_mask(k, u.dtype(), [](std::int64_t r, std::int64_t c) { return c <= r; });
  const Tensor strictly_lower = triangle_mask(k, u.dtype(), [](std::int64_t r, std::int64_t c) { return c < r; });
  const Tensor upper = triangle_mask(k, u.dtype(), [](std::int64_t r, std::int64_t c) { return c >= r; });
  const Tensor s = mul(p, lower) + transpose(mul(p, strictly_lower), 1, 2);
  const Tensor y = gt - matmul(s, ut);                     // [n, k, F]
  const Tensor r = mul(gemm(ut, vt, false, true), upper);  // [n, k, k]
  std::vector<Tensor> rows(static_cast<std::size_t>(k));
  for (std::int64_t i = k - 1; i >= 0; --i) {
    Tensor row = narrow(y, 1, i, 1);  // [n, 1, F]
    for (std::int64_t j = i + 1; j < k; ++j)
      row = row - mul(narrow(narrow(r, 1, i, 1), 2, j, 1), rows[static_cast<std::size_t>(j)]);
    rows[static_cast<std::size_t>(i)] = div(row, narrow(narrow(r, 1, i, 1), 2, i, 1));
  }
  return transpose(concat(rows, 1), 0, 1);
}

// The same rule as one pass per sample, not recorded: the backward without create_graph (a training step's), with no
// transposing copies and no [k, F] x [F, k] products of k = 4 rows (a quarter of MOORE's step went to those).
Tensor gram_schmidt_backward_kernel(const Tensor& g, const Tensor& u, const Tensor& v) {
  const std::int64_t k = u.size(0), n = u.size(1), width = u.size(2), stride = n * width;
  Tensor out = empty(u.shape(), u.dtype());
  dispatch_dtype(u.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const T* pg = g.data<T>();
    const T* pu = u.data<T>();
    const T* pv = v.data<T>();
    T* po = out.data<T>();
    parallel_for(n, std::max<std::int64_t>(1, detail::kElementwiseGrain / std::max<std::int64_t>(1, k * width)),
                 [&](std::int64_t s0, std::int64_t s1) {
                   std::vector<T> s_matrix(static_cast<std::size_t>(k * k)), r(static_cast<std::size_t>(k * k));
                   auto dot = [width](const T* a, const T* b) {
                     T total = 0;
                     for (std::int64_t f = 0; f < width; ++f) total += a[f] * b[f];
                     return total;
                   };
                   for (std::int64_t s = s0; s < s1; ++s) {
                     const std::int64_t at = s * width;
                     // S = copyltu(g u^T): S_ij = <g_i, u_j> for j <= i, <g_j, u_i> above; R_ij = <u_i, v_j>, j >= i.
                     for (std::int64_t i = 0; i < k; ++i)
                       for (std::int64_t j = 0; j < k; ++j) {
                         s_matrix[static_cast<std::size_t>(i * k + j)] =
                             j <= i ? dot(pg + i * stride + at, pu + j * stride + at)
                                    : dot(pg + j * stride + at, pu + i * stride + at);
                         r[static_cast<std::size_t>(i * k + j)] =
                             j >= i ? dot(pu + i * stride + at, pv + j * stride + at) : T(0);
                       }
                     // x_i = (y_i - sum_{j>i} R_ij x_j) / R_ii with y_i = g_i - sum_j S_ij u_j, from the last row up.
                     for (std::int64_t i = k - 1; i >= 0; --i) {
                       T* xi = po + i * stride + at;
                       const T* gi = pg + i * stride + at;
                       for (std::int64_t f = 0; f < width; ++f) xi[f] = gi[f];
                       for (std::int64_t j = 0; j < k; ++j) {
                         const T c = s_matrix[static_cast<std::size_t>(i * k + j)];
                         const T* uj = pu + j * stride + at;
                         for (std::int64_t f = 0; f < width; ++f) xi[f] -= c * uj[f];
                       }
                       for (std::int64_t j = i + 1; j < k; ++j) {
                         const T c = r[static_cast<std::size_t>(i * k + j)];
                         const T* xj = po + j * stride + at;
                         for (std::int64_t f = 0; f < width; ++f) xi[f] -= c * xj[f];
                       }
                       const T inverse = T(1) / r[static_cast<std::size_t>(i * k + i)];
                       for (std::int64_t f = 0; f < width; ++f) xi[f] *= inverse;
                     }
                   }
                 });
  });
  return out;
}

}  // namespace

Tensor gram_schmidt(const Tensor& v) {
  detail::check_defined(v, "gram_schmidt", "input");
  if (v.dim() != 3)
    throw std::invalid_argument("gram_schmidt: expected [k, n, F] (k vectors of width F per sample), got " +
                                to_string(v.shape()));
  const std::int64_t k = v.size(0), n = v.size(1), width = v.size(2);
  if (k > width)
    throw std::invalid_argument("gram_schmidt: " + std::to_string(k) + " vectors cannot be orthonormal in width " +
                                std::to_string(width) + " (need k <= F), input " + to_string(v.shape()));
  Tensor out = empty(v.shape(), v.dtype());
  dispatch_dtype(v.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const T* pv = v.data<T>();
    T* pu = out.data<T>();
    const std::int64_t stride = n * width;  // from one vector of a sample to the next
    parallel_for(n, std::max<std::int64_t>(1, detail::kElementwiseGrain / std::max<std::int64_t>(1, k * width)),
                 [&](std::int64_t s0, std::int64_t s1) {
                   for (std::int64_t s = s0; s < s1; ++s) {
                     for (std::int64_t i = 0; i < k; ++i) {
                       const T* vi = pv + i * stride + s * width;
                       T* ui = pu + i * stride + s * width;
                       for (std::int64_t f = 0; f < width; ++f) ui[f] = vi[f];
                       // Classical: every projection coefficient from v_i itself, as MOORE's layer computes them.
                       for (std::int64_t j = 0; j < i; ++j) {
                         const T* uj = pu + j * stride + s * width;
                         T dot = 0;
                         for (std::int64_t f = 0; f < width; ++f) dot += vi[f] * uj[f];
                         for (std::int64_t f = 0; f < width; ++f) ui[f] -= dot * uj[f];
                       }
                       T norm = 0;
                       for (std::int64_t f = 0; f < width; ++f) norm += ui[f] * ui[f];
                       const T inverse = T(1) / std::sqrt(norm);
                       for (std::int64_t f = 0; f < width; ++f) ui[f] *= inverse;
                     }
                   }
                 });
  });
  return record(
      "gram_schmidt", out, {v},
      [v](const Tensor& g, const Needs&, Node& self) {
        const Tensor u = self.output();
        if (!GradMode::is_enabled()) return Grads{gram_schmidt_backward_kernel(g, u, v)};
        return Grads{gram_schmidt_backward(g, u, v)};
      },
      true);
}

}  // namespace maps::ag
