// Elementwise unary ops. Rules that need the output use Node::output() (saved without a cycle).
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using detail::kTranscendentalGrain;
using detail::scalar_of;
using detail::unary_kernel;
using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

namespace {
// A constant (graph-free) 0/1 mask of where pred(x) holds, as x's dtype.
template <typename Pred>
Tensor mask_of(const Tensor& x, Pred pred) {
  NoGradGuard no_grad;
  return unary_kernel(x, "mask", [pred](const auto& a) {
    using T = scalar_of<decltype(a)>;
    return a.unaryExpr([pred](T v) { return pred(v) ? T(1) : T(0); });
  });
}
// softplus(a) = max(a, 0) + log1p(e) with e = exp(-|a|): no overflow for large a, no loss of precision for very
// negative a. softplus, mish and mish's rule each evaluate it (mish's rule reuses e for the sigmoid).
template <typename A, typename E>
auto stable_softplus(const A& a, const E& e) {
  return a.max(scalar_of<A>(0)) + e.log1p();
}

}  // namespace

Tensor neg(const Tensor& x) {
  Tensor out = unary_kernel(x, "neg", [](const auto& a) { return -a; });
  return record(
      "neg", out, {x}, [](const Tensor& g, const Needs&, Node&) { return Grads{neg(g)}; }, false, Reads::none());
}

Tensor exp(const Tensor& x) {
  Tensor out = unary_kernel(
      x, "exp", [](const auto& a) { return a.exp(); }, kTranscendentalGrain);
  return record(
      "exp", out, {x}, [](const Tensor& g, const Needs&, Node& self) { return Grads{mul(g, self.output())}; }, true,
      Reads::none());
}

Tensor log(const Tensor& x) {
  Tensor out = unary_kernel(
      x, "log", [](const auto& a) { return a.log(); }, kTranscendentalGrain);
  return record("log", out, {x}, [x](const Tensor& g, const Needs&, Node&) { return Grads{div(g, x)}; });
}

Tensor sqrt(const Tensor& x) {
  Tensor out = unary_kernel(x, "sqrt", [](const auto& a) { return a.sqrt(); });
  return record(
      "sqrt", out, {x},
      [](const Tensor& g, const Needs&, Node& self) { return Grads{div(mul(g, 0.5), self.output())}; }, true,
      Reads::none());
}

Tensor abs(const Tensor& x) {
  Tensor out = unary_kernel(x, "abs", [](const auto& a) { return a.abs(); });
  return record("abs", out, {x}, [x](const Tensor& g, const Needs&, Node&) {
    Tensor sign;
    {
      NoGradGuard no_grad;
      sign = unary_kernel(x, "sign", [](const auto& a) { return a.sign(); });
    }
    return Grads{mul(g, sign)};
  });
}

Tensor clamp(const Tensor& x, double min, double max) {
  if (!(min <= max)) {
    throw std::invalid_argument("clamp: min (" + std::to_string(min) + ") must not exceed max (" + std::to_string(max) +
                                ")");
  }
  Tensor out = unary_kernel(x, "clamp", [min, max](const auto& a) {
    using T = scalar_of<decltype(a)>;
    return a.max(static_cast<T>(min)).min(static_cast<T>(max));
  });
  return record("clamp", out, {x}, [x, min, max](const Tensor& g, const Needs&, Node&) {
    return Grads{mul(g, mask_of(x, [min, max](auto v) { return v >= min && v <= max; }))};
  });
}

Tensor clamp_min(const Tensor& x, double min) { return clamp(x, min, std::numeric_limits<double>::infinity()); }
Tensor clamp_max(const Tensor& x, double max) { return clamp(x, -std::numeric_limits<double>::infinity(), max); }

Tensor relu(const Tensor& x) {
  Tensor out = unary_kernel(x, "relu", [](const auto& a) { return a.max(scalar_of<decltype(a)>(0)); });
  return record("relu", out, {x}, [x](const Tensor& g, const Needs&, Node&) {
    return Grads{mul(g, mask_of(x, [](auto v) { return v > 0; }))};
  });
}

Tensor tanh(const Tensor& x) {
  Tensor out = unary_kernel(
      x, "tanh", [](const auto& a) { return a.tanh(); }, kTranscendentalGrain);
  return record(
      "tanh", out, {x},
      [](const Tensor& g, const Needs&, Node& self) { return Grads{tanh_backward(g, self.output())}; }, true,
      Reads::none());
}

namespace {
// An elementwise backward op's operands: the gradient and the tensor the rule reads (`name`), defined, of one dtype
// and one shape.
void check_backward_operands(const Tensor& grad, const Tensor& other, const char* name, const char* op) {
  detail::check_defined(grad, op, "gradient");
  detail::check_defined(other, op, name);
  detail::check_same_dtype(grad, other, op);
  if (grad.shape() != other.shape())
    throw std::invalid_argument(std::string(op) + ": gradient " + to_string(grad.shape()) + " and " + name + " " +
                                to_string(other.shape()) + " must have the same shape");
}
}  // namespace

Tensor tanh_backward(const Tensor& grad, const Tensor& output) {
  check_backward_operands(grad, output, "output", "tanh_backward");
  Tensor out = empty(grad.shape(), grad.dtype());
  dispatch_dtype(grad.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    const T* g = grad.data<T>();
    const T* y = output.data<T>();
    T* o = out.data<T>();
    detail::parallel_elementwise(out.numel(), [&](std::int64_t begin, std::int64_t end) {
      for (std::int64_t i = begin; i < end; ++i) o[i] = g[i] * (T(1) - y[i] * y[i]);
    });
  });
  return record("tanh_backward", out, {grad, output}, [grad, output](const Tensor& gg, const Needs& need, Node&) {
    Grads grads(2);
    if (need[0]) grads[0] = tanh_backward(gg, output);
    if (need[1]) grads[1] = mul(mul(gg, grad), mul(output, -2.0));
    return grads;
  });
}

Tensor softplus(const Tensor& x) {
  Tensor out = unary_kernel(
      x, "softplus", [](const auto& a) { return stable_softplus(a, (-a.abs()).exp()); }, kTranscendentalGrain);
  return record("softplus", out, {x}, [x](const Tensor& g, const Needs&, Node&) { return Grads{mul(g, sigmoid(x))}; });
}

Tensor mish(const Tensor& x) {
  Tensor out = unary_kernel(
      x, "mish", [](const auto& a) { return a * stable_softplus(a, (-a.abs()).exp()).tanh(); }, kTranscendentalGrain);
  return record("mish", out, {x}, [x](const Tensor& g, const Needs&, Node&) { return Grads{mish_backward(g, x)}; });
}

Tensor mish_backward(const Tensor& grad, const Tensor& x) {
  check_backward_operands(grad, x, "input", "mish_backward");
  // d/dx x tanh(sp(x)) = t + x (1 - t^2) sigmoid(x), t = tanh(sp(x)); sp and sigmoid from one exp(-|x|), in Eigen's
  // vectorised functions (scalar std::tanh and std::exp made this pass slower than the ops it replaces).
  Tensor out = empty(x.shape(), x.dtype());
  dispatch_dtype(x.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
    const T* g = grad.data<T>();
    const T* v = x.data<T>();
    T* o = out.data<T>();
    detail::parallel_elementwise(
        out.numel(),
        [&](std::int64_t begin, std::int64_t end) {
          const Eigen::Map<const Array> a(v + begin, end - begin), ga(g + begin, end - begin);
          const Array e = (-a.abs()).exp();
          const Array t = stable_softplus(a, e).tanh();
          const Array s = (a >= T(0)).select(T(1) / (T(1) + e), e / (T(1) + e));
          Eigen::Map<Array>(o + begin, end - begin) = ga * (t + a * (T(1) - t * t) * s);
        },
        kTranscendentalGrain);
  });
  return record("mish_backward", out, {grad, x}, [grad, x](const Tensor& gg, const Needs& need, Node&) {
    Grads grads(2);
    if (need[0]) grads[0] = mish_backward(gg, x);
    if (need[1]) {
      // mish''(x) = (1 - t^2) s (2 + x (1 - s - 2 t s)), written in ops so that it has derivatives of its own.
      const Tensor t = tanh(softplus(x)), s = sigmoid(x);
      const Tensor second = mul(mul(rsub(1.0, square(t)), s), add(mul(x, rsub(1.0, add(s, mul(mul(t, s), 2.0)))), 2.0));
      grads[1] = mul(mul(gg, grad), second);
    }
    return grads;
  });
}

Tensor erf(const Tensor& x) {
  Tensor out = unary_kernel(
      x, "erf",
      [](const auto& a) {
        using T = scalar_of<decltype(a)>;
        return a.unaryExpr([](T v) { return std::erf(v); });
      },
      kTranscendentalGrain);
  return record("erf", out, {x}, [x](const Tensor& g, const Needs&, Node&) {
    return Grads{mul(g, mul(exp(neg(square(x))), 2.0 / std::sqrt(3.14159265358979323846)))};
  });
}

Tensor sigmoid(const Tensor& x) {
  Tensor out = unary_kernel(x, "sigmoid", [](const auto& a) {
    using T = scalar_of<decltype(a)>;
    return T(1) / (T(1) + (-a).exp());
  });
  return record(
      "sigmoid", out, {x},
      [](const Tensor& g, const Needs&, Node& self) {
        const Tensor y = self.output();
        return Grads{mul(g, mul(y, rsub(1.0, y)))};
      },
      true);
}

Tensor square(const Tensor& x) {
  Tensor out = unary_kernel(x, "square", [](const auto& a) { return a.square(); });
  return record("square", out, {x}, [x](const Tensor& g, const Needs&, Node&) { return Grads{mul(g, mul(x, 2.0))}; });
}

}  // namespace maps::ag
