#pragma once

// Internal helpers shared by the op files: dtype checks and the loops that walk broadcast
// operands. Not part of the public API; nn's functional ops (nn/functional.cpp) use the argument checks
// (check_defined, check_1d_layout) too, so that their refusals read as the ops' do.

#include <algorithm>
#include <string>
#include <type_traits>

#include "autograd/parallel.h"
#include "autograd/tensor.h"

namespace maps::ag::detail {

// Elements per thread below which splitting an elementwise pass costs more than it saves; for exp, log, tanh and
// pow (tens of cycles an element, not one) far fewer.
constexpr std::int64_t kElementwiseGrain = 16384;
constexpr std::int64_t kTranscendentalGrain = 2048;

// body(begin, end) over [0, count) split across the op threads (autograd/parallel.h), each range starting at a
// multiple of 16 elements: on 64-byte aligned storage every range is then aligned, so Eigen's vector loops take
// the same elements down the same (vector or scalar) path whatever the split, and results have the same bits on
// any thread count.
template <typename Body>
void parallel_elementwise(std::int64_t count, Body&& body, std::int64_t grain = kElementwiseGrain) {
  constexpr std::int64_t kUnit = 16;
  parallel_for((count + kUnit - 1) / kUnit, std::max<std::int64_t>(1, grain / kUnit),
               [&](std::int64_t u0, std::int64_t u1) { body(u0 * kUnit, std::min(count, u1 * kUnit)); });
}

// The element type of an Eigen expression passed as `const auto&`.
template <typename Expr>
using scalar_of = typename std::decay_t<Expr>::Scalar;

void check_defined(const Tensor& t, const char* op, const char* name);
// A defined tensor of the 1-D convolutions' layout [batch, channels, length] (conv1d and its adjoints, the U-Net's
// resampling in nn::functional).
void check_1d_layout(const Tensor& t, const char* op, const char* name);
void check_same_dtype(const Tensor& a, const Tensor& b, const char* op);
// The same, naming the two inputs in the message (for ops whose inputs have roles: x, weight, bias).
void check_same_dtype(const Tensor& a, const char* a_name, const Tensor& b, const char* b_name, const char* op);

// Offsets of one row (the last output dim) of a broadcast: element j of the row reads
// a[a_offset + j * a_step] and b[b_offset + j * b_step] (a step is 0 where that operand broadcasts).
struct BroadcastRow {
  std::int64_t out_offset, a_offset, b_offset;
};

struct BroadcastPlan {
  Shape out;
  std::int64_t inner = 1;  // length of a row
  std::int64_t a_step = 0, b_step = 0;
  std::vector<std::int64_t> a_strides, b_strides;  // per output dim, 0 where broadcast
};

BroadcastPlan plan_broadcast(const Shape& out, const Shape& a, const Shape& b);

template <typename Visit>
void for_each_broadcast_row(const BroadcastPlan& plan, Visit&& visit) {
  const std::size_t rank = plan.out.size();
  const std::int64_t rows = plan.inner == 0 ? 0 : numel_of(plan.out) / plan.inner;
  std::vector<std::int64_t> index(rank > 0 ? rank - 1 : 0, 0);
  std::int64_t a_offset = 0, b_offset = 0;
  for (std::int64_t row = 0; row < rows; ++row) {
    visit(BroadcastRow{row * plan.inner, a_offset, b_offset});
    // Odometer increment over the outer dims, keeping the operand offsets in step.
    for (std::size_t d = index.size(); d-- > 0;) {
      ++index[d];
      a_offset += plan.a_strides[d];
      b_offset += plan.b_strides[d];
      if (index[d] < plan.out[d]) break;
      a_offset -= plan.a_strides[d] * plan.out[d];
      b_offset -= plan.b_strides[d] * plan.out[d];
      index[d] = 0;
    }
  }
}

// out = f(a, b) elementwise with broadcasting; f is called on scalars of type T.
template <typename F>
Tensor binary_kernel(const Tensor& a, const Tensor& b, const char* op, F f) {
  check_defined(a, op, "first operand");
  check_defined(b, op, "second operand");
  check_same_dtype(a, b, op);
  const Shape out_shape = a.shape() == b.shape() ? a.shape() : broadcast_shapes(a.shape(), b.shape(), op);
  Tensor out = empty(out_shape, a.dtype());
  dispatch_dtype(a.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    auto scalar_f = [&f](T x, T y) { return static_cast<T>(f(x, y)); };
    if (a.shape() == b.shape()) {
      const T* pa = a.data<T>();
      const T* pb = b.data<T>();
      T* po = out.data<T>();
      parallel_elementwise(out.numel(), [&](std::int64_t begin, std::int64_t end) {
        Eigen::Map<Array>(po + begin, end - begin) =
            Eigen::Map<const Array>(pa + begin, end - begin)
                .binaryExpr(Eigen::Map<const Array>(pb + begin, end - begin), scalar_f);
      });
      return;
    }
    const T* pa = a.data<T>();
    const T* pb = b.data<T>();
    T* po = out.data<T>();
    if (b.numel() == 1) {
      // A one-element b only pads a's shape with 1s, so the output has a's elements in a's order.
      const T y = pb[0];
      out.array<T>() = a.array<T>().unaryExpr([&](T x) { return scalar_f(x, y); });
      return;
    }
    const BroadcastPlan plan = plan_broadcast(out_shape, a.shape(), b.shape());
    for_each_broadcast_row(plan, [&](const BroadcastRow& row) {
      Eigen::Map<Array> o(po + row.out_offset, plan.inner);
      if (plan.a_step == 1 && plan.b_step == 1) {
        o = Eigen::Map<const Array>(pa + row.a_offset, plan.inner)
                .binaryExpr(Eigen::Map<const Array>(pb + row.b_offset, plan.inner), scalar_f);
      } else if (plan.a_step == 1) {
        const T y = pb[row.b_offset];
        o = Eigen::Map<const Array>(pa + row.a_offset, plan.inner).unaryExpr([&](T x) { return scalar_f(x, y); });
      } else if (plan.b_step == 1) {
        const T x = pa[row.a_offset];
        o = Eigen::Map<const Array>(pb + row.b_offset, plan.inner).unaryExpr([&](T y) { return scalar_f(x, y); });
      } else {
        o.setConstant(scalar_f(pa[row.a_offset], pb[row.b_offset]));
      }
    });
  });
  return out;
}

// out = f(x) where f maps an Eigen array expression to an array expression (vectorised by Eigen).
template <typename F>
Tensor unary_kernel(const Tensor& x, const char* op, F f, std::int64_t grain = kElementwiseGrain) {
  check_defined(x, op, "input");
  Tensor out = empty(x.shape(), x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    const T* px = x.data<T>();
    T* po = out.data<T>();
    parallel_elementwise(
        out.numel(),
        [&](std::int64_t begin, std::int64_t end) {
          Eigen::Map<Array>(po + begin, end - begin) = f(Eigen::Map<const Array>(px + begin, end - begin));
        },
        grain);
  });
  return out;
}

// Splits a shape around `dim` into [outer, size, inner] for reductions and slicing.
struct DimSplit {
  std::int64_t outer, size, inner;
};
DimSplit split_at(const Shape& shape, std::int64_t dim);

}  // namespace maps::ag::detail
