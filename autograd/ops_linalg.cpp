// Matrix products through the GEMM kernel (autograd/gemm_kernel.h: the own float32 kernel, else Eigen's).
// Transposed operands are read in place, so neither the forward pass nor any backward rule copies a transpose.
#include <algorithm>
#include <stdexcept>
#include <string>

#include "autograd/gemm_kernel.h"
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
  // Plain variables, not structured bindings: clang 14 cannot capture those in the lambdas below.
  const auto a_dims = op_dims(a, transpose_a);
  const auto b_dims = op_dims(b, transpose_b);
  const auto n = a_dims.first, k = a_dims.second, kb = b_dims.first, m = b_dims.second;
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
    using detail::MatrixRef;
    const std::int64_t ar = a.size(-2), ac = a.size(-1), br = b.size(-2), bc = b.size(-1);
    if (tall) {
      detail::gemm_parallel(MatrixRef<const T>{a.data<T>(), batch * ar, ac, ac}, false,
                            MatrixRef<const T>{b.data<T>(), br, bc, bc}, transpose_b,
                            MatrixRef<T>{out.data<T>(), batch * n, m, m}, false);
      return;
    }
    if (batch == 1) {
      detail::gemm_parallel(MatrixRef<const T>{a.data<T>(), ar, ac, ac}, transpose_a,
                            MatrixRef<const T>{b.data<T>(), br, bc, bc}, transpose_b,
                            MatrixRef<T>{out.data<T>(), n, m, m}, false);
      return;
    }
    // Batch entries are independent products: the threads share them out.
    parallel_for(batch, 1, [&](std::int64_t first, std::int64_t last) {
      for (std::int64_t i = first; i < last; ++i) {
        detail::gemm_serial(MatrixRef<const T>{a.data<T>() + i * ar * ac, ar, ac, ac}, transpose_a,
                            MatrixRef<const T>{b.data<T>() + i * br * bc, br, bc, bc}, transpose_b,
                            MatrixRef<T>{out.data<T>() + i * n * m, n, m, m}, false);
      }
    });
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

const char* float32_gemm_kernel() { return detail::f32_kernel_name(detail::f32_kernel()); }

namespace detail {
std::atomic<int> gemm_flop_counters{0};
std::atomic<std::uint64_t> gemm_flops_counted{0};
}  // namespace detail

GemmFlopCounter::GemmFlopCounter() : start_(detail::gemm_flops_counted.load()) { ++detail::gemm_flop_counters; }
GemmFlopCounter::~GemmFlopCounter() { --detail::gemm_flop_counters; }
double GemmFlopCounter::flops() const { return static_cast<double>(detail::gemm_flops_counted.load() - start_); }

Tensor gemm(const Tensor& a, const Tensor& b, bool transpose_a, bool transpose_b) {
  return product("gemm", a, b, transpose_a, transpose_b);
}

Tensor matmul(const Tensor& a, const Tensor& b) { return product("matmul", a, b, false, false); }

}  // namespace maps::ag
