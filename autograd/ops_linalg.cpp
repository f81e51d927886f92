// Matrix products through Eigen's GEMM.
#include <stdexcept>
#include <string>

#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

[[noreturn]] void bad_matmul(const Tensor& a, const Tensor& b, const std::string& why) {
  throw std::invalid_argument("matmul: cannot multiply " + to_string(a.shape()) + " by " + to_string(b.shape()) + ": " +
                              why);
}

// C[i] = A[i] * B[i] for `batch` row-major matrices laid end to end (a batch stride of 0 reuses one matrix).
template <typename T>
void batched_gemm(const T* a, const T* b, T* c, std::int64_t batch, std::int64_t n, std::int64_t k, std::int64_t m,
                  std::int64_t a_stride, std::int64_t b_stride) {
  using Mat = Eigen::Matrix<T, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  for (std::int64_t i = 0; i < batch; ++i) {
    Eigen::Map<const Mat> ma(a + i * a_stride, n, k);
    Eigen::Map<const Mat> mb(b + i * b_stride, k, m);
    Eigen::Map<Mat> mc(c + i * n * m, n, m);
    mc.noalias() = ma * mb;
  }
}

}  // namespace

Tensor matmul(const Tensor& a, const Tensor& b) {
  detail::check_defined(a, "matmul", "first operand");
  detail::check_defined(b, "matmul", "second operand");
  detail::check_same_dtype(a, b, "matmul");
  const std::int64_t ra = a.dim(), rb = b.dim();
  if (!((ra == 2 && rb == 2) || (ra == 3 && rb == 3) || (ra == 3 && rb == 2))) {
    bad_matmul(a, b, "supported ranks are 2-d @ 2-d, 3-d @ 3-d and 3-d @ 2-d");
  }
  const std::int64_t k = a.size(-1);
  if (b.size(-2) != k)
    bad_matmul(a, b, "inner sizes " + std::to_string(k) + " and " + std::to_string(b.size(-2)) + " differ");
  if (ra == 3 && rb == 3 && a.size(0) != b.size(0)) {
    bad_matmul(a, b, "batch sizes " + std::to_string(a.size(0)) + " and " + std::to_string(b.size(0)) + " differ");
  }
  const std::int64_t n = a.size(-2), m = b.size(-1);
  const std::int64_t batch = ra == 3 ? a.size(0) : 1;
  Shape out_shape = ra == 3 ? Shape{batch, n, m} : Shape{n, m};
  Tensor out = empty(out_shape, a.dtype());
  dispatch_dtype(a.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    if (ra == 3 && rb == 2) {
      // One tall GEMM instead of `batch` small ones: the shared right operand makes [batch*n, k] @ [k, m].
      batched_gemm<T>(a.data<T>(), b.data<T>(), out.data<T>(), 1, batch * n, k, m, 0, 0);
    } else {
      batched_gemm<T>(a.data<T>(), b.data<T>(), out.data<T>(), batch, n, k, m, n * k, rb == 3 ? k * m : 0);
    }
  });
  return record("matmul", out, {a, b}, [a, b](const Tensor& g, const Needs& need, Node&) {
    Grads grads(2);
    if (need[0]) grads[0] = matmul(g, transpose(b, -1, -2));
    if (need[1]) {
      if (a.dim() == 3 && b.dim() == 2) {
        const std::int64_t rows = a.size(0) * a.size(1);
        grads[1] = matmul(transpose(reshape(a, {rows, a.size(2)}), 0, 1), reshape(g, {rows, g.size(2)}));
      } else {
        grads[1] = matmul(transpose(a, -1, -2), g);
      }
    }
    return grads;
  });
}

}  // namespace maps::ag
