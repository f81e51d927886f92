// Matrix products through Eigen's GEMM. Transposed operands are read in place (Eigen's
// .transpose() is a view), so neither the forward pass nor any backward rule copies a transpose.
#include <stdexcept>
#include <string>

#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

[[noreturn]] void bad_product(const char* op, const Tensor& a, const Tensor& b, const std::string& why) {
  throw std::invalid_argument(std::string(op) + ": cannot multiply " + to_string(a.shape()) + " by " +
                              to_string(b.shape()) + ": " + why);
}

// Rows and columns of op(X) for the last two dims of X.
std::pair<std::int64_t, std::int64_t> op_dims(const Tensor& x, bool transposed) {
  const std::int64_t r = x.size(-2), c = x.size(-1);
  return transposed ? std::pair{c, r} : std::pair{r, c};
}

// C = op(A) op(B) for one matrix pair; A is ar x ac and B is br x bc as stored.
template <typename T>
void gemm_one(const T* a, std::int64_t ar, std::int64_t ac, bool ta, const T* b, std::int64_t br, std::int64_t bc,
              bool tb, T* c) {
  Eigen::Map<const RowMatrix<T>> ma(a, ar, ac);
  Eigen::Map<const RowMatrix<T>> mb(b, br, bc);
  const std::int64_t n = ta ? ac : ar, m = tb ? br : bc;
  Eigen::Map<RowMatrix<T>> mc(c, n, m);
  if (!ta && !tb) {
    mc.noalias() = ma * mb;
  } else if (!ta && tb) {
    mc.noalias() = ma * mb.transpose();
  } else if (ta && !tb) {
    mc.noalias() = ma.transpose() * mb;
  } else {
    mc.noalias() = ma.transpose() * mb.transpose();
  }
}

}  // namespace

namespace {

// matmul and gemm share this; `op` names the public entry point in errors and in the graph.
Tensor product(const char* op, const Tensor& a, const Tensor& b, bool transpose_a, bool transpose_b) {
  detail::check_defined(a, op, "first operand");
  detail::check_defined(b, op, "second operand");
  detail::check_same_dtype(a, b, op);
  const std::int64_t ra = a.dim(), rb = b.dim();
  const bool tall = ra == 3 && rb == 2;  // [batch, n, k] @ [k, m]: one GEMM over batch * n rows
  if (!((ra == 2 && rb == 2) || (ra == 3 && rb == 3) || tall)) {
    bad_product(op, a, b, "supported ranks are 2-d @ 2-d, 3-d @ 3-d and 3-d @ 2-d");
  }
  if (tall && transpose_a) bad_product(op, a, b, "a 3-d left operand cannot be transposed against a 2-d right one");
  const auto [n, k] = op_dims(a, transpose_a);
  const auto [kb, m] = op_dims(b, transpose_b);
  if (k != kb) {
    bad_product(op, a, b,
                "inner sizes " + std::to_string(k) + " and " + std::to_string(kb) + " differ" +
                    (transpose_a || transpose_b ? " (after transposing)" : ""));
  }
  if (ra == 3 && rb == 3 && a.size(0) != b.size(0)) {
    bad_product(op, a, b, "batch sizes " + std::to_string(a.size(0)) + " and " + std::to_string(b.size(0)) + " differ");
  }
  const std::int64_t batch = ra == 3 ? a.size(0) : 1;
  Tensor out = empty(ra == 3 ? Shape{batch, n, m} : Shape{n, m}, a.dtype());
  dispatch_dtype(a.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const std::int64_t ar = a.size(-2), ac = a.size(-1), br = b.size(-2), bc = b.size(-1);
    if (tall) {
      gemm_one<T>(a.data<T>(), batch * ar, ac, false, b.data<T>(), br, bc, transpose_b, out.data<T>());
      return;
    }
    for (std::int64_t i = 0; i < batch; ++i) {
      gemm_one<T>(a.data<T>() + i * ar * ac, ar, ac, transpose_a, b.data<T>() + i * br * bc, br, bc, transpose_b,
                  out.data<T>() + i * n * m);
    }
  });
  return record(op, out, {a, b}, [a, b, transpose_a, transpose_b, tall](const Tensor& g, const Needs& need, Node&) {
    Grads grads(2);
    // C = op(A) op(B): dop(A) = G op(B)^T and dop(B) = op(A)^T G, transposed back where op transposed.
    if (need[0]) grads[0] = transpose_a ? gemm(b, g, transpose_b, true) : gemm(g, b, false, !transpose_b);
    if (need[1]) {
      if (tall) {
        // B is shared by every batch entry: its gradient sums over them, one GEMM over the flattened
        // rows.
        const Tensor a2 = reshape(a, {-1, a.size(-1)});
        const Tensor g2 = reshape(g, {-1, g.size(-1)});
        grads[1] = transpose_b ? gemm(g2, a2, true, false) : gemm(a2, g2, true, false);
      } else {
        grads[1] = transpose_b ? gemm(g, a, true, transpose_a) : gemm(a, g, !transpose_a, false);
      }
    }
    return grads;
  });
}

}  // namespace

Tensor gemm(const Tensor& a, const Tensor& b, bool transpose_a, bool transpose_b) {
  return product("gemm", a, b, transpose_a, transpose_b);
}

Tensor matmul(const Tensor& a, const Tensor& b) { return product("matmul", a, b, false, false); }

Tensor linear(const Tensor& x, const Tensor& weight, const Tensor& bias) {
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
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    Eigen::Map<RowMatrix<T>> o(out.data<T>(), x2.size(0), weight.size(0));
    o.noalias() = x2.detach().matrix<T>() * weight.matrix<T>().transpose();
    if (bias.defined())
      o.rowwise() += Eigen::Map<const Eigen::Matrix<T, 1, Eigen::Dynamic>>(bias.data<T>(), bias.numel());
  });
  std::vector<Tensor> inputs{x, weight};
  if (bias.defined()) inputs.push_back(bias);
  return record(
      "linear", out, inputs,
      [x2, weight, has_bias = bias.defined(), in_shape = x.shape()](const Tensor& g, const Needs& need, Node&) {
        const Tensor g2 = g.dim() == 2 ? g : reshape(g, {-1, g.size(-1)});
        Grads grads(has_bias ? 3 : 2);
        if (need[0]) grads[0] = reshape(matmul(g2, weight), in_shape);
        if (need[1]) grads[1] = gemm(g2, x2, true, false);
        if (has_bias && need[2]) grads[2] = sum(g2, {0});
        return grads;
      });
}

}  // namespace maps::ag
