// Broadcasting binary ops and their scalar forms.
#include <cmath>

#include "autograd/grad_mode.h"
#include "autograd/kernels.h"
#include "autograd/node.h"
#include "autograd/ops.h"

namespace maps::ag {

using detail::binary_kernel;
using Grads = std::vector<Tensor>;
using Needs = std::vector<bool>;

Tensor add(const Tensor& a, const Tensor& b) {
  Tensor out = binary_kernel(a, b, "add", [](auto x, auto y) { return x + y; });
  return record(
      "add", out, {a, b},
      [sa = a.shape(), sb = b.shape()](const Tensor& g, const Needs& n, Node&) {
        return Grads{n[0] ? sum_to(g, sa) : Tensor(), n[1] ? sum_to(g, sb) : Tensor()};
      },
      false, Reads::none());
}

Tensor sub(const Tensor& a, const Tensor& b) {
  Tensor out = binary_kernel(a, b, "sub", [](auto x, auto y) { return x - y; });
  return record(
      "sub", out, {a, b},
      [sa = a.shape(), sb = b.shape()](const Tensor& g, const Needs& n, Node&) {
        return Grads{n[0] ? sum_to(g, sa) : Tensor(), n[1] ? sum_to(neg(g), sb) : Tensor()};
      },
      false, Reads::none());
}

Tensor mul(const Tensor& a, const Tensor& b) {
  Tensor out = binary_kernel(a, b, "mul", [](auto x, auto y) { return x * y; });
  return record("mul", out, {a, b}, [a, b](const Tensor& g, const Needs& n, Node&) {
    return Grads{n[0] ? sum_to(mul(g, b), a.shape()) : Tensor(), n[1] ? sum_to(mul(g, a), b.shape()) : Tensor()};
  });
}

Tensor div(const Tensor& a, const Tensor& b) {
  Tensor out = binary_kernel(a, b, "div", [](auto x, auto y) { return x / y; });
  return record("div", out, {a, b}, [a, b](const Tensor& g, const Needs& n, Node&) {
    return Grads{n[0] ? sum_to(div(g, b), a.shape()) : Tensor(),
                 n[1] ? sum_to(neg(div(mul(g, a), mul(b, b))), b.shape()) : Tensor()};
  });
}

namespace {
// The share of the gradient that goes to `a` in minimum/maximum: 1 where a wins, 1/2 on ties.
template <typename Wins>
Tensor winner_share(const Tensor& a, const Tensor& b, const char* op, Wins wins) {
  return binary_kernel(a, b, op, [wins](auto x, auto y) {
    if (std::isnan(x) || std::isnan(y)) return std::isnan(x) ? 1.0 : 0.0;
    return wins(x, y) ? 1.0 : (x == y ? 0.5 : 0.0);
  });
}

template <typename Wins>
Tensor min_max(const Tensor& a, const Tensor& b, const char* op, Wins wins) {
  // A NaN on either side wins, as in PyTorch, so a NaN is never hidden.
  Tensor out = binary_kernel(a, b, op, [wins](auto x, auto y) { return wins(x, y) || std::isnan(x) ? x : y; });
  return record(op, out, {a, b}, [a, b, op, wins](const Tensor& g, const Needs& n, Node&) {
    Tensor share_a, share_b;
    {
      NoGradGuard no_grad;
      share_a = winner_share(a, b, op, wins);
      share_b = rsub(1.0, share_a);
    }
    return Grads{n[0] ? sum_to(mul(g, share_a), a.shape()) : Tensor(),
                 n[1] ? sum_to(mul(g, share_b), b.shape()) : Tensor()};
  });
}
}  // namespace

Tensor minimum(const Tensor& a, const Tensor& b) {
  return min_max(a, b, "minimum", [](auto x, auto y) { return x < y; });
}

Tensor maximum(const Tensor& a, const Tensor& b) {
  return min_max(a, b, "maximum", [](auto x, auto y) { return x > y; });
}

Tensor pow(const Tensor& base, const Tensor& exponent) {
  Tensor out = binary_kernel(base, exponent, "pow", [](auto x, auto y) { return std::pow(x, y); });
  return record(
      "pow", out, {base, exponent},
      [base, exponent](const Tensor& g, const Needs& n, Node& self) {
        // As PyTorch: d/dbase is 0 where the exponent is 0 (not 0 * pow(0, -1) = NaN), and
        // d/dexponent is 0 where the base is 0 and the exponent >= 0 (not pow * log(0)).
        Tensor exponent_zero, base_zero;
        {
          NoGradGuard no_grad;
          exponent_zero = binary_kernel(base, exponent, "pow", [](auto, auto y) { return y == 0 ? 1.0 : 0.0; });
          base_zero = binary_kernel(base, exponent, "pow", [](auto x, auto y) { return x == 0 && y >= 0 ? 1.0 : 0.0; });
        }
        const Tensor zero = zeros_like(g);
        Grads grads(2);
        if (n[0]) {
          const Tensor d = mul(g, mul(exponent, pow(base, add(exponent, -1.0))));
          grads[0] = sum_to(where(exponent_zero, zero, d), base.shape());
        }
        if (n[1]) {
          const Tensor d = mul(g, mul(self.output(), log(base)));
          grads[1] = sum_to(where(base_zero, zero, d), exponent.shape());
        }
        return grads;
      },
      /*save_output=*/true);
}

Tensor where(const Tensor& condition, const Tensor& a, const Tensor& b) {
  detail::check_defined(condition, "where", "condition");
  detail::check_defined(a, "where", "first operand");
  detail::check_defined(b, "where", "second operand");
  if (condition.shape() != a.shape() || a.shape() != b.shape()) {
    throw std::invalid_argument("where: condition " + to_string(condition.shape()) + ", a " + to_string(a.shape()) +
                                " and b " + to_string(b.shape()) + " must share one shape");
  }
  detail::check_same_dtype(a, b, "where");
  // An own copy: the backward rule routes by it, so a later in-place change of `condition` must not reach it.
  const Tensor picks_a = condition.dtype() == a.dtype() ? condition.detach().clone() : condition.detach().to(a.dtype());
  Tensor out = empty(a.shape(), a.dtype());
  dispatch_dtype(a.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    out.array<T>() = (picks_a.array<T>() != T(0)).select(a.array<T>(), b.array<T>());
  });
  return record(
      "where", out, {a, b},
      [picks_a](const Tensor& g, const Needs& n, Node&) {
        const Tensor zero = zeros_like(g);
        return Grads{n[0] ? where(picks_a, g, zero) : Tensor(), n[1] ? where(picks_a, zero, g) : Tensor()};
      },
      false, Reads::none());
}

Tensor add(const Tensor& a, double b) {
  Tensor out =
      detail::unary_kernel(a, "add", [b](const auto& x) { return x + static_cast<detail::scalar_of<decltype(x)>>(b); });
  return record(
      "add_scalar", out, {a}, [](const Tensor& g, const Needs&, Node&) { return Grads{g}; }, false, Reads::none());
}

Tensor mul(const Tensor& a, double b) {
  Tensor out =
      detail::unary_kernel(a, "mul", [b](const auto& x) { return x * static_cast<detail::scalar_of<decltype(x)>>(b); });
  return record(
      "mul_scalar", out, {a}, [b](const Tensor& g, const Needs&, Node&) { return Grads{mul(g, b)}; }, false,
      Reads::none());
}

Tensor rsub(double a, const Tensor& b) {
  Tensor out = detail::unary_kernel(b, "rsub",
                                    [a](const auto& x) { return static_cast<detail::scalar_of<decltype(x)>>(a) - x; });
  return record(
      "rsub", out, {b}, [](const Tensor& g, const Needs&, Node&) { return Grads{neg(g)}; }, false, Reads::none());
}

Tensor rdiv(double a, const Tensor& b) {
  Tensor out = detail::unary_kernel(b, "rdiv",
                                    [a](const auto& x) { return static_cast<detail::scalar_of<decltype(x)>>(a) / x; });
  return record(
      "rdiv", out, {b},
      [b](const Tensor& g, const Needs&, Node& self) { return Grads{neg(div(mul(g, self.output()), b))}; },
      /*save_output=*/true);
}

Tensor pow(const Tensor& base, double exponent) {
  Tensor out = detail::unary_kernel(
      base, "pow", [exponent](const auto& x) { return x.pow(static_cast<detail::scalar_of<decltype(x)>>(exponent)); },
      detail::kTranscendentalGrain);
  return record("pow_scalar", out, {base}, [base, exponent](const Tensor& g, const Needs&, Node&) {
    if (exponent == 0.0) return Grads{zeros_like(g)};
    if (exponent == 1.0) return Grads{g};
    if (exponent == 2.0) return Grads{mul(g, mul(base, 2.0))};
    return Grads{mul(g, mul(pow(base, exponent - 1.0), exponent))};
  });
}

Tensor gt(const Tensor& a, const Tensor& b) {
  return binary_kernel(a, b, "gt", [](auto x, auto y) { return x > y ? 1.0 : 0.0; });
}

Tensor eq(const Tensor& a, const Tensor& b) {
  return binary_kernel(a, b, "eq", [](auto x, auto y) { return x == y ? 1.0 : 0.0; });
}

}  // namespace maps::ag
