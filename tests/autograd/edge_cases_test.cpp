// Edge cases found in review: aliasing of stored gradients, overflowing sizes, NaN propagation,
// pow at a zero base, and where().
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Tensor;
using agtest::kF64;
using agtest::tensor;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(EdgeCases, CreateGraphBackwardNeverAliasesGradsAcrossLeaves) {
  Tensor a = tensor({1.0}, {}, kF64, true);
  Tensor b = tensor({2.0}, {}, kF64, true);
  ag::add(a, b).backward(Tensor(), false, /*create_graph=*/true);
  EXPECT_NE(a.grad().impl(), b.grad().impl());
  // A second pass accumulates in place into each leaf's own gradient: 2 each, not 3.
  ag::add(a, b).backward();
  EXPECT_DOUBLE_EQ(a.grad().item(), 2.0);
  EXPECT_DOUBLE_EQ(b.grad().item(), 2.0);
}

TEST(EdgeCases, CreateGraphBackwardDoesNotAliasTheCallersGradOutput) {
  Tensor x = tensor({1.0, 2.0}, {2}, kF64, true);
  Tensor seed = tensor({3.0, 4.0}, {2}, kF64);
  ag::add(x, 0.0).backward(seed, false, /*create_graph=*/true);
  seed.fill_(100.0);
  EXPECT_EQ(x.grad().to_vector(), (std::vector<double>{3.0, 4.0}));
}

TEST(EdgeCases, NarrowRejectsALengthThatOverflows) {
  const Tensor x = ag::zeros({2, 3});
  EXPECT_THROW(ag::narrow(x, 1, 1, std::numeric_limits<std::int64_t>::max()), std::invalid_argument);
}

TEST(EdgeCases, ShapesWhoseElementCountOverflowsAreRefused) {
  EXPECT_THROW(ag::zeros({std::int64_t{1} << 62, 4}), std::length_error);
  EXPECT_THROW(ag::zeros({std::int64_t{1} << 40, std::int64_t{1} << 40}), std::length_error);
}

TEST(EdgeCases, MinimumAndMaximumPropagateNaNFromEitherSide) {
  const Tensor a = tensor({kNaN, 1.0}, {2});
  const Tensor b = tensor({1.0, kNaN}, {2});
  for (const Tensor& r : {ag::minimum(a, b), ag::maximum(a, b), ag::minimum(b, a), ag::maximum(b, a)}) {
    EXPECT_TRUE(std::isnan(r.at(0)));
    EXPECT_TRUE(std::isnan(r.at(1)));
  }
}

TEST(EdgeCases, AmaxIsNaNWhereverTheNaNSits) {
  for (int position = 0; position < 17; ++position) {
    std::vector<double> values(17, 1.0);
    values[position] = kNaN;
    EXPECT_TRUE(std::isnan(ag::amax(tensor(values, {17})).item())) << "NaN at " << position;
  }
  // Over one dim: only the slices holding a NaN become NaN.
  const Tensor m = tensor({1.0, kNaN, 3.0, 4.0, 5.0, 6.0}, {2, 3});
  const Tensor rows = ag::amax(m, {1});
  EXPECT_TRUE(std::isnan(rows.at(0)));
  EXPECT_DOUBLE_EQ(rows.at(1), 6.0);
  const Tensor cols = ag::amax(m, {0});
  EXPECT_DOUBLE_EQ(cols.at(0), 4.0);
  EXPECT_TRUE(std::isnan(cols.at(1)));
  EXPECT_DOUBLE_EQ(cols.at(2), 6.0);
}

TEST(EdgeCases, PowGradientsAtAZeroBaseMatchPyTorch) {
  Tensor base = tensor({0.0, 0.0, 2.0}, {3}, kF64, true);
  Tensor exponent = tensor({0.0, 2.0, 0.0}, {3}, kF64, true);
  const std::vector<Tensor> g = ag::grad({ag::sum(ag::pow(base, exponent))}, {base, exponent});
  EXPECT_EQ(g[0].to_vector(), (std::vector<double>{0.0, 0.0, 0.0}));
  EXPECT_EQ(g[1].at(0), 0.0);
  EXPECT_EQ(g[1].at(1), 0.0);
  EXPECT_NEAR(g[1].at(2), std::log(2.0), 1e-15);
}

TEST(EdgeCases, WhereSelectsAndRoutesGradients) {
  const Tensor condition = tensor({1.0, 0.0, 2.0, 0.0}, {2, 2});
  Tensor a = tensor({1.0, 2.0, 3.0, 4.0}, {2, 2}, kF64, true);
  Tensor b = tensor({-1.0, -2.0, -3.0, -4.0}, {2, 2}, kF64, true);
  EXPECT_EQ(ag::where(condition, a, b).to_vector(), (std::vector<double>{1.0, -2.0, 3.0, -4.0}));
  agtest::expect_grad_and_gradgrad(
      "where", [&condition](const std::vector<Tensor>& in) { return ag::where(condition, in[0], in[1]); }, {a, b});
  EXPECT_THROW(ag::where(condition, a, tensor({1.0, 2.0}, {2}, kF64)), std::invalid_argument);
}

TEST(EdgeCases, BadArgumentsGetClearErrors) {
  EXPECT_THROW(ag::arange(0.0, std::numeric_limits<double>::infinity()), std::invalid_argument);
  EXPECT_THROW(ag::arange(0.0, kNaN), std::invalid_argument);
  Tensor undefined;
  EXPECT_THROW(undefined.fill_(1.0), std::logic_error);
  EXPECT_THROW(ag::index_add(ag::zeros({1, 2}), {0}, -1), std::invalid_argument);
}

}  // namespace
