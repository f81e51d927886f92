// Elementwise unary ops: neg, exp, log, sqrt, abs, clamp (both sides, min, max), relu, tanh,
// sigmoid, square, erf, softplus, mish.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Dtype;
using ag::Shape;
using ag::Tensor;
using agtest::expect_grad_and_gradgrad;
using agtest::expect_values;
using agtest::kBothDtypes;
using agtest::kF32;
using agtest::kF64;
using agtest::tensor;

using Generate = std::function<Tensor(const Shape&, std::uint64_t)>;

struct UnaryCase {
  std::string name;
  std::function<Tensor(const Tensor&)> op;
  std::function<double(double)> ref;
  Generate gen;  // inputs kept away from the op's kinks and outside its domain's edge
};

Tensor normal(const Shape& s, std::uint64_t seed) { return agtest::randn64(s, seed); }
Tensor positive(const Shape& s, std::uint64_t seed) { return agtest::uniform64(s, 0.5, 2.0, seed); }
Tensor nonzero(const Shape& s, std::uint64_t seed) { return agtest::away_from_zero64(s, seed, 0.2, 1.5); }

double sigmoid_ref(double x) { return 1.0 / (1.0 + std::exp(-x)); }

std::vector<UnaryCase> unary_cases() {
  return {
      {"neg", [](const Tensor& x) { return ag::neg(x); }, [](double x) { return -x; }, normal},
      {"exp", [](const Tensor& x) { return ag::exp(x); }, [](double x) { return std::exp(x); }, normal},
      {"log", [](const Tensor& x) { return ag::log(x); }, [](double x) { return std::log(x); }, positive},
      {"sqrt", [](const Tensor& x) { return ag::sqrt(x); }, [](double x) { return std::sqrt(x); }, positive},
      {"abs", [](const Tensor& x) { return ag::abs(x); }, [](double x) { return std::abs(x); }, nonzero},
      {"clamp", [](const Tensor& x) { return ag::clamp(x, -0.5, 0.8); },
       [](double x) { return std::clamp(x, -0.5, 0.8); },
       [](const Shape& s, std::uint64_t seed) {
         return agtest::avoiding64(s, -2.0, 2.0, {-0.5, 0.8}, seed);
       }},
      {"clamp_min", [](const Tensor& x) { return ag::clamp_min(x, 0.3); }, [](double x) { return std::max(x, 0.3); },
       [](const Shape& s, std::uint64_t seed) { return agtest::avoiding64(s, -1.5, 2.0, {0.3}, seed); }},
      {"clamp_max", [](const Tensor& x) { return ag::clamp_max(x, -0.2); }, [](double x) { return std::min(x, -0.2); },
       [](const Shape& s, std::uint64_t seed) { return agtest::avoiding64(s, -2.0, 1.5, {-0.2}, seed); }},
      {"relu", [](const Tensor& x) { return ag::relu(x); }, [](double x) { return std::max(x, 0.0); }, nonzero},
      {"tanh", [](const Tensor& x) { return ag::tanh(x); }, [](double x) { return std::tanh(x); }, normal},
      {"sigmoid", [](const Tensor& x) { return ag::sigmoid(x); }, sigmoid_ref, normal},
      {"square", [](const Tensor& x) { return ag::square(x); }, [](double x) { return x * x; }, normal},
      {"erf", [](const Tensor& x) { return ag::erf(x); }, [](double x) { return std::erf(x); }, normal},
      {"softplus", [](const Tensor& x) { return ag::softplus(x); }, [](double x) { return std::log1p(std::exp(x)); },
       normal},
      {"mish", [](const Tensor& x) { return ag::mish(x); },
       [](double x) { return x * std::tanh(std::log1p(std::exp(x))); }, normal},
  };
}

const std::vector<Shape> kShapes = {{}, {5}, {2, 3}, {2, 3, 4}};

class UnaryOpTest : public ::testing::TestWithParam<UnaryCase> {};

TEST_P(UnaryOpTest, ForwardMatchesReference) {
  const UnaryCase& c = GetParam();
  std::uint64_t seed = 10;
  for (const Shape& shape : kShapes) {
    for (Dtype dtype : kBothDtypes) {
      SCOPED_TRACE(ag::to_string(shape) + " " + ag::to_string(dtype));
      const Tensor x = c.gen(shape, seed++).detach().to(dtype);
      std::vector<double> expected = x.to_vector();
      for (double& v : expected) v = c.ref(v);
      const Tensor y = c.op(x);
      EXPECT_EQ(y.dtype(), dtype);
      EXPECT_FALSE(y.requires_grad());
      expect_values(y, shape, expected, agtest::tolerance(dtype));
    }
  }
}

TEST_P(UnaryOpTest, Gradcheck) {
  const UnaryCase& c = GetParam();
  std::uint64_t seed = 20;
  for (const Shape& shape : kShapes) {
    SCOPED_TRACE(ag::to_string(shape));
    auto f = [op = c.op](const std::vector<Tensor>& in) { return op(in[0]); };
    agtest::expect_gradcheck(c.name, f, {c.gen(shape, seed++)});
  }
}

TEST_P(UnaryOpTest, Gradgradcheck) {
  const UnaryCase& c = GetParam();
  std::uint64_t seed = 30;
  for (const Shape& shape : {Shape{}, Shape{2, 3}, Shape{2, 3, 4}}) {
    SCOPED_TRACE(ag::to_string(shape));
    auto f = [op = c.op](const std::vector<Tensor>& in) { return op(in[0]); };
    agtest::expect_gradgradcheck(c.name, f, {c.gen(shape, seed++)});
  }
}

TEST_P(UnaryOpTest, RecordsNodeNamedAfterOp) {
  const UnaryCase& c = GetParam();
  const Tensor y = c.op(c.gen({3}, 40));
  EXPECT_TRUE(y.requires_grad());
  ASSERT_NE(y.grad_fn(), nullptr);
  // clamp_min and clamp_max may record as "clamp": the node's name starts the op's name.
  EXPECT_EQ(c.name.rfind(y.grad_fn()->op(), 0), 0u) << "node " << y.grad_fn()->op() << " for op " << c.name;
}

INSTANTIATE_TEST_SUITE_P(AllUnaryOps, UnaryOpTest, ::testing::ValuesIn(unary_cases()),
                         [](const ::testing::TestParamInfo<UnaryCase>& info) { return info.param.name; });

// ----- hand-computed values and gradients at the edges -----

TEST(UnaryOps, HandComputedValues) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const double tol = agtest::tolerance(dtype);
    const Tensor x = tensor({-2, -0.5, 0, 0.5, 2}, {5}, dtype);
    expect_values(ag::relu(x), {5}, {0, 0, 0, 0.5, 2}, tol);
    expect_values(ag::abs(x), {5}, {2, 0.5, 0, 0.5, 2}, tol);
    expect_values(ag::clamp(x, -1, 1), {5}, {-1, -0.5, 0, 0.5, 1}, tol);
    expect_values(ag::clamp_min(x, 0.25), {5}, {0.25, 0.25, 0.25, 0.5, 2}, tol);
    expect_values(ag::clamp_max(x, 0.25), {5}, {-2, -0.5, 0, 0.25, 0.25}, tol);
    expect_values(ag::square(x), {5}, {4, 0.25, 0, 0.25, 4}, tol);
    expect_values(ag::neg(x), {5}, {2, 0.5, 0, -0.5, -2}, tol);
    expect_values(ag::sigmoid(tensor({0}, {}, dtype)), {}, {0.5}, tol);
    expect_values(ag::tanh(tensor({0}, {}, dtype)), {}, {0}, tol);
    expect_values(ag::exp(tensor({0, 1}, {2}, dtype)), {2}, {1, std::exp(1.0)}, tol);
    expect_values(ag::log(tensor({1, std::exp(2.0)}, {2}, dtype)), {2}, {0, 2}, 1e-6);
    expect_values(ag::sqrt(tensor({4, 0.25}, {2}, dtype)), {2}, {2, 0.5}, tol);
  }
}

TEST(UnaryOps, AbsGradientIsZeroAtZero) {
  const Tensor x = tensor({-2, 0, 3}, {3}, kF64, true);
  ag::sum(ag::abs(x)).backward();
  expect_values(x.grad(), {3}, {-1, 0, 1});
}

TEST(UnaryOps, ClampGradientPassesInsideAndAtTheBounds) {
  const Tensor x = tensor({-2, -1, 0, 1, 2}, {5}, kF64, true);
  ag::sum(ag::clamp(x, -1, 1)).backward();
  expect_values(x.grad(), {5}, {0, 1, 1, 1, 0});
  const Tensor y = tensor({-1, 0.5, 1}, {3}, kF64, true);
  ag::sum(ag::clamp_min(y, 0.5) + ag::clamp_max(y, 0.5)).backward();
  expect_values(y.grad(), {3}, {1, 2, 1});
}

TEST(UnaryOps, HandComputedGradients) {
  const Tensor x = tensor({-1, 0.5, 2}, {3}, kF64, true);
  ag::sum(ag::relu(x)).backward();
  expect_values(x.grad(), {3}, {0, 1, 1});

  const Tensor t = tensor({0.3, -1.2}, {2}, kF64, true);
  ag::sum(ag::tanh(t) + ag::sigmoid(t) + ag::exp(t) + ag::square(t)).backward();
  std::vector<double> expected;
  for (double v : {0.3, -1.2}) {
    const double th = std::tanh(v);
    const double s = sigmoid_ref(v);
    expected.push_back((1 - th * th) + s * (1 - s) + std::exp(v) + 2 * v);
  }
  expect_values(t.grad(), {2}, expected);

  const Tensor p = tensor({0.25, 4}, {2}, kF64, true);
  ag::sum(ag::log(p) + ag::sqrt(p)).backward();
  expect_values(p.grad(), {2}, {1 / 0.25 + 0.5 / 0.5, 1 / 4.0 + 0.5 / 2.0});
}

TEST(UnaryOps, SaturatingOpsStayFiniteAtExtremes) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    Tensor x = tensor({-1000, -50, 50, 1000}, {4}, dtype, true);
    const Tensor s = ag::sigmoid(x);
    const Tensor t = ag::tanh(x);
    expect_values(s, {4}, {0, sigmoid_ref(-50), 1, 1}, 1e-6);
    expect_values(t, {4}, {-1, -1, 1, 1}, 1e-6);
    ag::sum(s + t).backward();
    for (double g : x.grad().to_vector()) {
      EXPECT_TRUE(std::isfinite(g));
      EXPECT_NEAR(g, 0.0, 1e-6);
    }
  }
}

// softplus is computed stably: log1p(exp(x)) overflows past x = 88 in float32; the op gives x there, and its
// gradient, sigmoid(x), stays in [0, 1].
TEST(UnaryOps, SoftplusIsStableAtExtremes) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    Tensor x = tensor({-1000, -100, 100, 1000}, {4}, dtype, true);
    const Tensor y = ag::softplus(x);
    const std::vector<double> values = y.to_vector();
    EXPECT_GE(values[0], 0.0);
    EXPECT_LE(values[0], 1e-300);
    EXPECT_GE(values[1], 0.0);
    EXPECT_LE(values[1], 1e-40);
    EXPECT_EQ(values[2], 100.0);
    EXPECT_EQ(values[3], 1000.0);
    ag::sum(y).backward();
    expect_values(x.grad(), {4}, {0, 0, 1, 1}, 1e-6);
  }
}

// mish by hand: mish(0) = 0 with slope tanh(ln 2) = 0.6; mish(1) = tanh(ln(1 + e)); far out it is x (slope 1) and 0
// (slope 0), finite in float32 where exp would overflow.
TEST(UnaryOps, MishHandValuesAndExtremes) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    Tensor x = tensor({0, 1, -1000, 1000}, {4}, dtype, true);
    const Tensor y = ag::mish(x);
    expect_values(y, {4}, {0, 0.8650983882673103, 0, 1000}, agtest::tolerance(dtype));
    ag::sum(y).backward();
    // mish'(1) = tanh(sp(1)) + (1 - tanh(sp(1))^2) sigmoid(1).
    const double t = 0.8650983882673103;
    expect_values(x.grad(), {4}, {0.6, t + (1 - t * t) * sigmoid_ref(1.0), 0, 1}, agtest::tolerance(dtype));
  }
}

// mish_backward, mish's rule in one pass, against the rule written in ops; both its derivatives checked numerically.
TEST(UnaryOps, MishBackwardIsMishsRuleInOnePass) {
  const Tensor x = agtest::randn64({3, 4}, 31, false) * 3.0, g = agtest::randn64({3, 4}, 32, false);
  const Tensor t = ag::tanh(ag::softplus(x));
  agtest::expect_close(ag::mish_backward(g, x), g * (t + x * (1.0 - t * t) * ag::sigmoid(x)), 1e-14);
  expect_grad_and_gradgrad("mish_backward",
                           [](const std::vector<Tensor>& in) { return ag::mish_backward(in[0], in[1]); },
                           {agtest::randn64({2, 3}, 33), agtest::randn64({2, 3}, 34)});
  agtest::expect_throw_with([] { ag::mish_backward(ag::zeros({2, 3}), ag::zeros({3, 2})); }, {"same shape"});
  agtest::expect_throw_with([] { ag::mish_backward(ag::zeros({2}), ag::zeros({2}, kF64)); }, {"dtypes differ"});
}

TEST(UnaryOps, CompositeGradgradcheck) {
  auto f = [](const std::vector<Tensor>& in) {
    const Tensor& x = in[0];
    return ag::tanh(ag::sigmoid(x) * 2.0) * ag::exp(ag::neg(ag::square(x))) +
           ag::log(ag::add(ag::square(x), 1.0)) * ag::sqrt(ag::add(ag::abs(x), 0.5));
  };
  expect_grad_and_gradgrad("composite", f, {agtest::away_from_zero64({2, 3}, 5)});
}

}  // namespace

namespace {

// Elementwise ops split their ranges on multiples of 16 elements, so Eigen's vector loops take every element down
// the same path on any thread count: the same bits on one thread and two (33,001 elements: split off the middle).
TEST(UnaryOps, SameBitsOnOneAndTwoThreads) {
  for (const Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    ag::Generator gen(21);
    const Tensor x = ag::rand({33001}, gen, dtype, 0.1, 3.0);
    const std::vector<std::function<Tensor(const Tensor&)>> ops = {
        [](const Tensor& t) { return ag::exp(t); }, [](const Tensor& t) { return ag::log(t); },
        [](const Tensor& t) { return ag::tanh(t); }, [](const Tensor& t) { return ag::pow(t, 0.4343); },
        [](const Tensor& t) { return ag::square(t); }};
    for (std::size_t i = 0; i < ops.size(); ++i) {
      const std::vector<double> one = ops[i](x).to_vector();
      ag::set_num_threads(2);
      const std::vector<double> two = ops[i](x).to_vector();
      ag::set_num_threads(1);
      for (std::size_t j = 0; j < one.size(); ++j) ASSERT_EQ(one[j], two[j]) << "op " << i << " at " << j;
    }
  }
}

}  // namespace
