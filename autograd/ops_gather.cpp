// gather_add: the sum of two row lookups with an activation in one pass (MAPS's selector first layer for every
// state under every task: a state's part plus its task's row).
#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {

void check_rows(const std::vector<std::int64_t>& rows, std::int64_t size, const char* which) {
  for (std::size_t i = 0; i < rows.size(); ++i)
    if (rows[i] < 0 || rows[i] >= size)
      throw std::out_of_range(std::string("gather_add: ") + which + " index " + std::to_string(rows[i]) +
                              " at position " + std::to_string(i) + " is outside [0, " + std::to_string(size) + ")");
}

// Both tables' gradients in one pass over the output's gradient, not recorded (grad mode off): each row's
// gradient before the activation is added to its two source rows. Rows repeat, so each thread's range of rows
// adds into tables of its own, summed in range order afterwards. (Split by columns instead, each thread read half
// of every row and the pass took 2.4x the CPU time of one thread: the Modified set's 16,896 rows x 128.)
Grads scatter_gradients(const Tensor& g, const Tensor& output, const std::vector<std::int64_t>& a_rows,
                        std::int64_t a_size, const std::vector<std::int64_t>& b_rows, std::int64_t b_size,
                        const Needs& need) {
  const std::int64_t rows = g.size(0), width = g.size(1);
  const std::int64_t ranges =
      parallel_ranges(rows, std::max<std::int64_t>(1, detail::kElementwiseGrain / std::max<std::int64_t>(width, 1)));
  std::vector<Tensor> a_parts(static_cast<std::size_t>(std::max<std::int64_t>(ranges, 1)));
  std::vector<Tensor> b_parts(a_parts.size());
  for (std::size_t r = 0; r < a_parts.size(); ++r) {
    a_parts[r] = zeros({a_size, width}, g.dtype());
    b_parts[r] = zeros({b_size, width}, g.dtype());
  }
  dispatch_dtype(g.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    const T* pg = g.data<T>();
    const T* py = output.defined() ? output.data<T>() : nullptr;
    parallel_for_ranges(rows, ranges, [&](std::int64_t range, std::int64_t r0, std::int64_t r1) {
      T* da = a_parts[static_cast<std::size_t>(range)].data<T>();
      T* db = b_parts[static_cast<std::size_t>(range)].data<T>();
      Array gz(width);
      for (std::int64_t r = r0; r < r1; ++r) {
        const Eigen::Map<const Array> gr(pg + r * width, width);
        if (py != nullptr) {
          const Eigen::Map<const Array> y(py + r * width, width);
          gz = gr * (T(1) - y * y);
        } else {
          gz = gr;
        }
        Eigen::Map<Array>(da + a_rows[static_cast<std::size_t>(r)] * width, width) += gz;
        Eigen::Map<Array>(db + b_rows[static_cast<std::size_t>(r)] * width, width) += gz;
      }
    });
    for (std::size_t r = 1; r < a_parts.size(); ++r) {
      Eigen::Map<Array>(a_parts[0].data<T>(), a_size * width) +=
          Eigen::Map<const Array>(a_parts[r].data<T>(), a_size * width);
      Eigen::Map<Array>(b_parts[0].data<T>(), b_size * width) +=
          Eigen::Map<const Array>(b_parts[r].data<T>(), b_size * width);
    }
  });
  Grads grads{a_parts[0], b_parts[0]};
  if (!need[0]) grads[0] = Tensor();
  if (!need[1]) grads[1] = Tensor();
  return grads;
}

}  // namespace

Tensor gather_add(const Tensor& a, const std::vector<std::int64_t>& a_rows, const Tensor& b,
                  const std::vector<std::int64_t>& b_rows, Fused activation) {
  detail::check_defined(a, "gather_add", "first table");
  detail::check_defined(b, "gather_add", "second table");
  detail::check_same_dtype(a, b, "gather_add");
  if (a.dim() != 2 || b.dim() != 2 || a.size(1) != b.size(1))
    throw std::invalid_argument("gather_add: tables must be 2-d with the same row length, got " + to_string(a.shape()) +
                                " and " + to_string(b.shape()));
  if (a_rows.size() != b_rows.size())
    throw std::invalid_argument("gather_add: " + std::to_string(a_rows.size()) + " rows of the first table but " +
                                std::to_string(b_rows.size()) + " of the second");
  check_rows(a_rows, a.size(0), "first table's");
  check_rows(b_rows, b.size(0), "second table's");
  const std::int64_t rows = static_cast<std::int64_t>(a_rows.size()), width = a.size(1);
  Tensor out = empty({rows, width}, a.dtype());
  dispatch_dtype(a.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    const T* pa = a.data<T>();
    const T* pb = b.data<T>();
    T* po = out.data<T>();
    parallel_for(rows, std::max<std::int64_t>(1, detail::kElementwiseGrain / std::max<std::int64_t>(width, 1)),
                 [&](std::int64_t r0, std::int64_t r1) {
                   for (std::int64_t r = r0; r < r1; ++r) {
                     Eigen::Map<Array> o(po + r * width, width);
                     const Eigen::Map<const Array> x(pa + a_rows[static_cast<std::size_t>(r)] * width, width);
                     const Eigen::Map<const Array> y(pb + b_rows[static_cast<std::size_t>(r)] * width, width);
                     if (activation == Fused::Tanh) {
                       o = (x + y).tanh();
                     } else {
                       o = x + y;
                     }
                   }
                 });
  });
  return record(
      activation == Fused::Tanh ? "gather_add_tanh" : "gather_add", out, {a, b},
      [a_rows, b_rows, a_size = a.size(0), b_size = b.size(0), activation](const Tensor& g, const Needs& need,
                                                                           Node& self) {
        if (!GradMode::is_enabled())
          return scatter_gradients(g, activation == Fused::Tanh ? self.output() : Tensor(), a_rows, a_size, b_rows,
                                   b_size, need);
        const Tensor gz = activation == Fused::Tanh ? tanh_backward(g, self.output()) : g;
        Grads grads(2);
        if (need[0]) grads[0] = index_add(gz, a_rows, a_size);
        if (need[1]) grads[1] = index_add(gz, b_rows, b_size);
        return grads;
      },
      activation != Fused::None);
}

}  // namespace maps::ag
