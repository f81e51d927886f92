// Elementwise binary ops with NumPy broadcasting (add, sub, mul, div, minimum, maximum, pow),
// ops with a scalar operand, and comparisons.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
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
using agtest::expect_gradcheck;
using agtest::expect_gradgradcheck;
using agtest::expect_throw_with;
using agtest::expect_values;
using agtest::kBothDtypes;
using agtest::kF32;
using agtest::kF64;
using agtest::tensor;

using Generate = std::function<Tensor(const Shape&, std::uint64_t)>;

Tensor normal(const Shape& s, std::uint64_t seed) { return agtest::randn64(s, seed); }
Tensor nonzero(const Shape& s, std::uint64_t seed) { return agtest::away_from_zero64(s, seed, 0.5, 1.5); }
Tensor positive(const Shape& s, std::uint64_t seed) { return agtest::uniform64(s, 0.5, 2.0, seed); }
// Multiples of 0.3, and multiples of 0.3 shifted by 0.15: the two never tie, whatever broadcasts.
Tensor grid(const Shape& s, std::uint64_t seed) { return agtest::distinct64(s, seed, 0.3, 0.0); }
Tensor grid_half(const Shape& s, std::uint64_t seed) { return agtest::distinct64(s, seed, 0.3, 0.15); }

struct BinaryCase {
  std::string name;
  std::function<Tensor(const Tensor&, const Tensor&)> op;
  std::function<double(double, double)> ref;
  Generate gen_a;
  Generate gen_b;
};

std::vector<BinaryCase> binary_cases() {
  return {
      {"add", [](const Tensor& a, const Tensor& b) { return ag::add(a, b); }, std::plus<double>(), normal, normal},
      {"sub", [](const Tensor& a, const Tensor& b) { return ag::sub(a, b); }, std::minus<double>(), normal, normal},
      {"mul", [](const Tensor& a, const Tensor& b) { return ag::mul(a, b); }, std::multiplies<double>(), normal,
       normal},
      {"div", [](const Tensor& a, const Tensor& b) { return ag::div(a, b); }, std::divides<double>(), normal, nonzero},
      {"minimum", [](const Tensor& a, const Tensor& b) { return ag::minimum(a, b); },
       [](double a, double b) { return std::min(a, b); }, grid, grid_half},
      {"maximum", [](const Tensor& a, const Tensor& b) { return ag::maximum(a, b); },
       [](double a, double b) { return std::max(a, b); }, grid, grid_half},
      {"pow", [](const Tensor& a, const Tensor& b) { return ag::pow(a, b); },
       [](double a, double b) { return std::pow(a, b); }, positive, normal},
  };
}

struct ShapePair {
  Shape a;
  Shape b;
};

// Same shapes, trailing-dim broadcast, both sides broadcasting, rank-3 with rank-2, and scalars.
const std::vector<ShapePair> kShapePairs = {
    {{2, 3}, {2, 3}}, {{3, 4}, {4}},       {{3, 1}, {1, 4}}, {{2, 3, 4}, {3, 1}}, {{}, {2, 3}}, {{2, 3}, {}},
    {{4}, {2, 1, 4}}, {{2, 1, 3}, {4, 1}}, {{}, {}},
};

std::string pair_name(const ShapePair& p) { return ag::to_string(p.a) + " with " + ag::to_string(p.b); }

class BinaryOpTest : public ::testing::TestWithParam<BinaryCase> {};

TEST_P(BinaryOpTest, ForwardMatchesReferenceWithBroadcasting) {
  const BinaryCase& c = GetParam();
  std::uint64_t seed = 100;
  for (const ShapePair& p : kShapePairs) {
    for (Dtype dtype : kBothDtypes) {
      SCOPED_TRACE(pair_name(p) + " " + ag::to_string(dtype));
      const Tensor a = c.gen_a(p.a, seed++).detach().to(dtype);
      const Tensor b = c.gen_b(p.b, seed++).detach().to(dtype);
      Shape out_shape;
      const std::vector<double> expected =
          agtest::broadcast_ref(a.to_vector(), p.a, b.to_vector(), p.b, c.ref, &out_shape);
      const Tensor y = c.op(a, b);
      EXPECT_EQ(y.dtype(), dtype);
      EXPECT_FALSE(y.requires_grad());
      expect_values(y, out_shape, expected, agtest::tolerance(dtype));
    }
  }
}

TEST_P(BinaryOpTest, GradcheckBothInputsWithBroadcasting) {
  const BinaryCase& c = GetParam();
  std::uint64_t seed = 200;
  for (const ShapePair& p : kShapePairs) {
    SCOPED_TRACE(pair_name(p));
    const Tensor a = c.gen_a(p.a, seed++);
    const Tensor b = c.gen_b(p.b, seed++);
    auto f = [op = c.op](const std::vector<Tensor>& in) { return op(in[0], in[1]); };
    expect_gradcheck(c.name, f, {a, b});
  }
}

TEST_P(BinaryOpTest, GradcheckOneInputRequiringGrad) {
  const BinaryCase& c = GetParam();
  auto f = [op = c.op](const std::vector<Tensor>& in) { return op(in[0], in[1]); };
  const Tensor a = c.gen_a({3, 4}, 1);
  const Tensor b = c.gen_b({4}, 2).detach();
  expect_gradcheck(c.name, f, {a, b});
  const Tensor a2 = c.gen_a({3, 1}, 3).detach();
  const Tensor b2 = c.gen_b({1, 4}, 4);
  expect_gradcheck(c.name, f, {a2, b2});
}

TEST_P(BinaryOpTest, GradgradcheckWithBroadcasting) {
  const BinaryCase& c = GetParam();
  std::uint64_t seed = 300;
  for (const ShapePair& p :
       {ShapePair{{2, 3}, {2, 3}}, ShapePair{{3, 1}, {1, 4}}, ShapePair{{2, 3, 4}, {3, 1}}, ShapePair{{}, {2, 3}}}) {
    SCOPED_TRACE(pair_name(p));
    const Tensor a = c.gen_a(p.a, seed++);
    const Tensor b = c.gen_b(p.b, seed++);
    auto f = [op = c.op](const std::vector<Tensor>& in) { return op(in[0], in[1]); };
    expect_gradgradcheck(c.name, f, {a, b});
  }
}

TEST_P(BinaryOpTest, BroadcastGradientsHaveTheInputShapes) {
  const BinaryCase& c = GetParam();
  const Tensor a = c.gen_a({3, 1}, 5);
  const Tensor b = c.gen_b({2, 1, 4}, 6);
  Tensor y = ag::sum(c.op(a, b));
  y.backward();
  ASSERT_TRUE(a.grad().defined());
  ASSERT_TRUE(b.grad().defined());
  EXPECT_EQ(a.grad().shape(), (Shape{3, 1}));
  EXPECT_EQ(b.grad().shape(), (Shape{2, 1, 4}));
  EXPECT_EQ(a.grad().dtype(), kF64);
}

TEST_P(BinaryOpTest, ShapeMismatchNamesOpAndBothShapes) {
  const BinaryCase& c = GetParam();
  for (Dtype dtype : kBothDtypes) {
    const Tensor a = ag::ones({2, 3}, dtype);
    const Tensor b = ag::ones({4}, dtype);
    expect_throw_with([&] { c.op(a, b); }, agtest::names(c.name, {2, 3}, {4}));
    expect_throw_with([&] { c.op(b, a); }, agtest::names(c.name, {4}, {2, 3}));
    expect_throw_with(
        [&] {
          c.op(ag::ones({2, 3, 4}, dtype), ag::ones({2, 1, 3}, dtype));
        },
        agtest::names(c.name, {2, 3, 4}, {2, 1, 3}));
  }
}

TEST_P(BinaryOpTest, DtypeMismatchNamesOp) {
  const BinaryCase& c = GetParam();
  expect_throw_with([&] { c.op(ag::ones({2, 3}, kF32), ag::ones({2, 3}, kF64)); }, {c.name});
  expect_throw_with([&] { c.op(ag::ones({3}, kF64), ag::ones({2, 3}, kF32)); }, {c.name});
}

TEST_P(BinaryOpTest, RecordsNodeNamedAfterOp) {
  const BinaryCase& c = GetParam();
  const Tensor a = c.gen_a({2}, 7);
  const Tensor b = c.gen_b({2}, 8);
  const Tensor y = c.op(a, b);
  EXPECT_TRUE(y.requires_grad());
  ASSERT_NE(y.grad_fn(), nullptr);
  EXPECT_EQ(y.grad_fn()->op(), c.name);
}

INSTANTIATE_TEST_SUITE_P(AllBinaryOps, BinaryOpTest, ::testing::ValuesIn(binary_cases()),
                         [](const ::testing::TestParamInfo<BinaryCase>& info) { return info.param.name; });

// ----- hand-computed values -----

TEST(BinaryOps, HandComputedValues) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const double tol = agtest::tolerance(dtype);
    const Tensor a = tensor({1, 2, 3, 4, 5, 6}, {2, 3}, dtype);
    const Tensor row = tensor({10, 20, 30}, {3}, dtype);
    const Tensor col = tensor({2, 4}, {2, 1}, dtype);
    expect_values(a + row, {2, 3}, {11, 22, 33, 14, 25, 36}, tol);
    expect_values(a - col, {2, 3}, {-1, 0, 1, 0, 1, 2}, tol);
    expect_values(a * col, {2, 3}, {2, 4, 6, 16, 20, 24}, tol);
    expect_values(a / col, {2, 3}, {0.5, 1, 1.5, 1, 1.25, 1.5}, tol);
    expect_values(ag::pow(a, col), {2, 3}, {1, 4, 9, 256, 625, 1296}, tol);
    expect_values(ag::minimum(a, tensor({3}, {}, dtype)), {2, 3}, {1, 2, 3, 3, 3, 3}, tol);
    expect_values(ag::maximum(a, tensor({3}, {}, dtype)), {2, 3}, {3, 3, 3, 4, 5, 6}, tol);
    expect_values(tensor({2}, {}, dtype) * tensor({3}, {}, dtype), {}, {6}, tol);
  }
}

TEST(BinaryOps, HandComputedGradients) {
  const Tensor a = tensor({1, 2, 3, 4, 5, 6}, {2, 3}, kF64, true);
  const Tensor b = tensor({2, 4}, {2, 1}, kF64, true);
  ag::sum(a * b).backward();
  expect_values(a.grad(), {2, 3}, {2, 2, 2, 4, 4, 4});
  expect_values(b.grad(), {2, 1}, {6, 15});

  const Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor y = tensor({4, 8}, {2}, kF64, true);
  ag::sum(x / y).backward();
  expect_values(x.grad(), {2}, {0.25, 0.125});
  expect_values(y.grad(), {2}, {-1.0 / 16, -2.0 / 64});

  const Tensor base = tensor({2, 3}, {2}, kF64, true);
  const Tensor expo = tensor({3, 2}, {2}, kF64, true);
  ag::sum(ag::pow(base, expo)).backward();
  expect_values(base.grad(), {2}, {3 * 4.0, 2 * 3.0});
  expect_values(expo.grad(), {2}, {8 * std::log(2.0), 9 * std::log(3.0)});
}

TEST(BinaryOps, MinimumMaximumTiesSplitGradientEvenly) {
  const Tensor a = tensor({1, 2, 5}, {3}, kF64, true);
  const Tensor b = tensor({1, 3, 4}, {3}, kF64, true);
  ag::sum(ag::minimum(a, b)).backward();
  expect_values(a.grad(), {3}, {0.5, 1, 0});
  expect_values(b.grad(), {3}, {0.5, 0, 1});

  const Tensor c = tensor({1, 2, 5}, {3}, kF64, true);
  const Tensor d = tensor({1, 3, 4}, {3}, kF64, true);
  ag::sum(ag::maximum(c, d)).backward();
  expect_values(c.grad(), {3}, {0.5, 0, 1});
  expect_values(d.grad(), {3}, {0.5, 1, 0});
}

// ----- with a scalar -----

struct ScalarCase {
  std::string name;
  std::function<Tensor(const Tensor&)> op;
  std::function<double(double)> ref;
  Generate gen;
};

std::vector<ScalarCase> scalar_cases() {
  return {
      {"add_scalar", [](const Tensor& x) { return ag::add(x, 2.5); }, [](double x) { return x + 2.5; }, normal},
      {"mul_scalar", [](const Tensor& x) { return ag::mul(x, -1.5); }, [](double x) { return x * -1.5; }, normal},
      {"rsub", [](const Tensor& x) { return ag::rsub(2.0, x); }, [](double x) { return 2.0 - x; }, normal},
      {"rdiv", [](const Tensor& x) { return ag::rdiv(2.0, x); }, [](double x) { return 2.0 / x; }, nonzero},
      {"pow_2", [](const Tensor& x) { return ag::pow(x, 2.0); }, [](double x) { return x * x; }, normal},
      {"pow_3", [](const Tensor& x) { return ag::pow(x, 3.0); }, [](double x) { return x * x * x; }, normal},
      {"pow_1", [](const Tensor& x) { return ag::pow(x, 1.0); }, [](double x) { return x; }, normal},
      {"pow_0", [](const Tensor& x) { return ag::pow(x, 0.0); }, [](double) { return 1.0; }, positive},
      {"pow_half", [](const Tensor& x) { return ag::pow(x, 0.5); }, [](double x) { return std::sqrt(x); }, positive},
      {"pow_minus_1_5", [](const Tensor& x) { return ag::pow(x, -1.5); }, [](double x) { return std::pow(x, -1.5); },
       positive},
      {"pow_2_5", [](const Tensor& x) { return ag::pow(x, 2.5); }, [](double x) { return std::pow(x, 2.5); }, positive},
      {"op_plus_left", [](const Tensor& x) { return 3.0 + x; }, [](double x) { return 3.0 + x; }, normal},
      {"op_minus", [](const Tensor& x) { return x - 0.75; }, [](double x) { return x - 0.75; }, normal},
      {"op_rminus", [](const Tensor& x) { return 0.75 - x; }, [](double x) { return 0.75 - x; }, normal},
      {"op_times_left", [](const Tensor& x) { return 4.0 * x; }, [](double x) { return 4.0 * x; }, normal},
      {"op_divide", [](const Tensor& x) { return x / 4.0; }, [](double x) { return x / 4.0; }, normal},
      {"op_rdivide", [](const Tensor& x) { return 3.0 / x; }, [](double x) { return 3.0 / x; }, nonzero},
      {"op_neg", [](const Tensor& x) { return -x; }, [](double x) { return -x; }, normal},
  };
}

class ScalarOpTest : public ::testing::TestWithParam<ScalarCase> {};

const std::vector<Shape> kUnaryShapes = {{}, {5}, {2, 3}, {2, 3, 4}};

TEST_P(ScalarOpTest, ForwardMatchesReference) {
  const ScalarCase& c = GetParam();
  std::uint64_t seed = 400;
  for (const Shape& shape : kUnaryShapes) {
    for (Dtype dtype : kBothDtypes) {
      SCOPED_TRACE(ag::to_string(shape) + " " + ag::to_string(dtype));
      const Tensor x = c.gen(shape, seed++).detach().to(dtype);
      std::vector<double> expected = x.to_vector();
      for (double& v : expected) v = c.ref(v);
      const Tensor y = c.op(x);
      EXPECT_EQ(y.dtype(), dtype);
      expect_values(y, shape, expected, agtest::tolerance(dtype));
    }
  }
}

TEST_P(ScalarOpTest, GradcheckAndGradgradcheck) {
  const ScalarCase& c = GetParam();
  std::uint64_t seed = 500;
  for (const Shape& shape : kUnaryShapes) {
    SCOPED_TRACE(ag::to_string(shape));
    auto f = [op = c.op](const std::vector<Tensor>& in) { return op(in[0]); };
    expect_grad_and_gradgrad(c.name, f, {c.gen(shape, seed++)});
  }
}

INSTANTIATE_TEST_SUITE_P(AllScalarOps, ScalarOpTest, ::testing::ValuesIn(scalar_cases()),
                         [](const ::testing::TestParamInfo<ScalarCase>& info) { return info.param.name; });

TEST(BinaryOps, TensorExponentPowOfNegativeBaseWithIntegerExponent) {
  // A float exponent tensor holding integers gives real results for negative bases, like PyTorch.
  const Tensor base = tensor({-2, -1.5, 3}, {3});
  const Tensor expo = tensor({3, 2, 2}, {3});
  expect_values(ag::pow(base, expo), {3}, {-8, 2.25, 9});
}

// ----- comparisons -----

TEST(Comparisons, GtAndEqValuesWithBroadcastingRecordNoGraph) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    Tensor a = tensor({1, 2, 3, 4, 5, 6}, {2, 3}, dtype, true);
    Tensor b = tensor({2, 2, 7}, {3}, dtype, true);
    const Tensor g = ag::gt(a, b);
    const Tensor e = ag::eq(a, b);
    EXPECT_EQ(g.dtype(), dtype);
    expect_values(g, {2, 3}, {0, 0, 0, 1, 1, 0});
    expect_values(e, {2, 3}, {0, 1, 0, 0, 0, 0});
    EXPECT_FALSE(g.requires_grad());
    EXPECT_FALSE(e.requires_grad());
    EXPECT_EQ(g.grad_fn(), nullptr);
    expect_values(ag::gt(a, tensor({3}, {}, dtype)), {2, 3}, {0, 0, 0, 1, 1, 1});
    expect_values(ag::eq(tensor({3}, {}, dtype), a), {2, 3}, {0, 0, 1, 0, 0, 0});
  }
  expect_throw_with([] { ag::gt(ag::ones({2, 3}), ag::ones({4})); }, agtest::names("gt", {2, 3}, {4}));
  expect_throw_with([] { ag::eq(ag::ones({2, 3}), ag::ones({4})); }, agtest::names("eq", {2, 3}, {4}));
}

// ----- chains of binary ops: second derivatives of products and quotients -----

TEST(BinaryOps, CompositeGradgradcheck) {
  auto f = [](const std::vector<Tensor>& in) {
    const Tensor& x = in[0];
    const Tensor& y = in[1];
    return ag::div(ag::mul(x, ag::add(x, y)), ag::add(ag::mul(y, y), 1.0)) - ag::pow(x, 2.0) * 0.5;
  };
  expect_grad_and_gradgrad("x*(x+y)/(y*y+1)-x^2/2", f, {agtest::randn64({2, 3}, 11), agtest::randn64({3}, 12)});
}

}  // namespace
