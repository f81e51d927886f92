// softmax and log_softmax over a dim.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
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
using agtest::expect_throw_with;
using agtest::expect_values;
using agtest::kBothDtypes;
using agtest::kF64;
using agtest::randn64;
using agtest::tensor;

using Inputs = std::vector<Tensor>;

// Reference (log-)softmax of row-major values over `dim` (normalised).
std::vector<double> softmax_ref(const std::vector<double>& x, const Shape& shape, std::int64_t dim, bool log) {
  std::int64_t outer = 1, inner = 1;
  for (std::int64_t d = 0; d < dim; ++d) outer *= shape[static_cast<std::size_t>(d)];
  for (std::size_t d = static_cast<std::size_t>(dim) + 1; d < shape.size(); ++d) inner *= shape[d];
  const std::int64_t n = shape[static_cast<std::size_t>(dim)];
  std::vector<double> out(x.size());
  for (std::int64_t o = 0; o < outer; ++o)
    for (std::int64_t i = 0; i < inner; ++i) {
      auto at = [&](std::int64_t j) { return static_cast<std::size_t>((o * n + j) * inner + i); };
      double mx = x[at(0)];
      for (std::int64_t j = 1; j < n; ++j) mx = std::max(mx, x[at(j)]);
      double z = 0;
      for (std::int64_t j = 0; j < n; ++j) z += std::exp(x[at(j)] - mx);
      for (std::int64_t j = 0; j < n; ++j) {
        out[at(j)] = log ? x[at(j)] - mx - std::log(z) : std::exp(x[at(j)] - mx) / z;
      }
    }
  return out;
}

struct SoftmaxCase {
  Shape shape;
  std::int64_t dim;
};

const std::vector<SoftmaxCase> kSoftmaxCases = {{{5}, 0},       {{2, 3}, 1},     {{2, 3}, 0},    {{2, 3}, -1},
                                                {{2, 3, 4}, 1}, {{2, 3, 4}, -1}, {{2, 3, 4}, 0}, {{1, 4}, 0}};

std::string case_name(const SoftmaxCase& c) { return ag::to_string(c.shape) + " dim " + std::to_string(c.dim); }

std::int64_t norm(const SoftmaxCase& c) {
  return c.dim < 0 ? c.dim + static_cast<std::int64_t>(c.shape.size()) : c.dim;
}

class SoftmaxTest : public ::testing::TestWithParam<bool> {};  // true: log_softmax

Tensor apply(bool log, const Tensor& x, std::int64_t dim) {
  return log ? ag::log_softmax(x, dim) : ag::softmax(x, dim);
}

const char* op_name(bool log) { return log ? "log_softmax" : "softmax"; }

TEST_P(SoftmaxTest, ForwardMatchesReference) {
  const bool log = GetParam();
  std::uint64_t seed = 1;
  for (const SoftmaxCase& c : kSoftmaxCases) {
    for (Dtype dtype : kBothDtypes) {
      SCOPED_TRACE(case_name(c) + " " + ag::to_string(dtype));
      const Tensor x = ag::mul(randn64(c.shape, seed++, false), 2.0).to(dtype);
      const Tensor y = apply(log, x, c.dim);
      EXPECT_EQ(y.dtype(), dtype);
      expect_values(y, c.shape, softmax_ref(x.to_vector(), c.shape, norm(c), log), agtest::tolerance(dtype) * 10);
    }
  }
}

TEST_P(SoftmaxTest, StableForLargeInputs) {
  const bool log = GetParam();
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = tensor({1000, 1001, 1002, -1000, -1001, -1002}, {2, 3}, dtype, true);
    const Tensor y = apply(log, x, 1);
    const std::vector<double> expected = softmax_ref({0, 1, 2, 0, -1, -2}, {2, 3}, 1, log);
    expect_values(y, {2, 3}, expected, 1e-5);
    ag::sum(ag::mul(y, tensor({1, 2, 3, 4, 5, 6}, {2, 3}, dtype))).backward();
    for (double g : x.grad().to_vector()) EXPECT_TRUE(std::isfinite(g));
  }
}

TEST_P(SoftmaxTest, Gradcheck) {
  const bool log = GetParam();
  std::uint64_t seed = 100;
  for (const SoftmaxCase& c : kSoftmaxCases) {
    SCOPED_TRACE(case_name(c));
    const std::int64_t dim = c.dim;
    auto f = [log, dim](const Inputs& in) { return apply(log, in[0], dim); };
    agtest::expect_gradcheck(op_name(log), f, {randn64(c.shape, seed++)});
  }
}

TEST_P(SoftmaxTest, Gradgradcheck) {
  const bool log = GetParam();
  std::uint64_t seed = 200;
  for (const SoftmaxCase& c : kSoftmaxCases) {
    SCOPED_TRACE(case_name(c));
    const std::int64_t dim = c.dim;
    auto f = [log, dim](const Inputs& in) { return apply(log, in[0], dim); };
    agtest::expect_gradgradcheck(op_name(log), f, {randn64(c.shape, seed++)});
  }
}

TEST_P(SoftmaxTest, BadDimNamesOp) {
  const bool log = GetParam();
  expect_throw_with([&] { apply(log, ag::ones({2, 3}), 2); }, {op_name(log)});
  expect_throw_with([&] { apply(log, ag::ones({2, 3}), -3); }, {op_name(log)});
}

INSTANTIATE_TEST_SUITE_P(Both, SoftmaxTest, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& info) { return std::string(op_name(info.param)); });

TEST(Softmax, RowsSumToOneAndLogSoftmaxIsLogOfSoftmax) {
  const Tensor x = randn64({3, 4}, 9, false);
  expect_values(ag::sum(ag::softmax(x, 1), {1}), {3}, {1, 1, 1});
  expect_values(ag::sum(ag::softmax(x, 0), {0}), {4}, {1, 1, 1, 1});
  agtest::expect_close(ag::log_softmax(x, 1), ag::log(ag::softmax(x, 1)));
  expect_values(ag::softmax(tensor({0, 0}, {2}), 0), {2}, {0.5, 0.5});
}

TEST(Softmax, HandComputedGradients) {
  // d/dx of sum(w * softmax(x)) = s * (w - sum(w * s)).
  const Tensor x = tensor({0.5, -1, 2}, {3}, kF64, true);
  const std::vector<double> w = {1, 2, 3};
  ag::sum(ag::mul(ag::softmax(x, 0), tensor(w, {3}))).backward();
  const std::vector<double> s = softmax_ref({0.5, -1, 2}, {3}, 0, false);
  const double ws = w[0] * s[0] + w[1] * s[1] + w[2] * s[2];
  expect_values(x.grad(), {3}, {s[0] * (w[0] - ws), s[1] * (w[1] - ws), s[2] * (w[2] - ws)});
  // d/dx of sum(w * log_softmax(x)) = w - s * sum(w).
  const Tensor y = tensor({0.5, -1, 2}, {3}, kF64, true);
  ag::sum(ag::mul(ag::log_softmax(y, 0), tensor(w, {3}))).backward();
  expect_values(y.grad(), {3}, {1 - 6 * s[0], 2 - 6 * s[1], 3 - 6 * s[2]});
}

TEST(Softmax, CrossEntropyCompositeGradgradcheck) {
  // Mean cross-entropy of logits against one-hot targets.
  const Tensor targets = ag::one_hot({2, 0, 1}, 4, kF64);
  auto ce = [targets](const Inputs& in) {
    return ag::neg(ag::mean(ag::sum(ag::mul(targets, ag::log_softmax(in[0], 1)), {1})));
  };
  expect_grad_and_gradgrad("cross entropy", ce, {randn64({3, 4}, 3)});
  // Attention-like: softmax of a product, weighting values.
  auto attention = [](const Inputs& in) {
    return ag::matmul(ag::softmax(ag::matmul(in[0], ag::transpose(in[1], 0, 1)), -1), in[1]);
  };
  expect_grad_and_gradgrad("attention", attention, {randn64({2, 3}, 4), randn64({4, 3}, 5)});
}

}  // namespace

namespace {

// The last-dim softmax's exp runs on whole ranges of rows: a value's result must not depend on where a thread's
// range starts (3300 rows of 10 split on two threads), and values far down (-inf, -100) must give 0, as std::exp.
TEST(Softmax, LastDimSameBitsOnOneAndTwoThreadsAndZeroForMinusInfinity) {
  for (const Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = randn64({3300, 10}, 77, false).to(dtype) * 3.0;
    const std::vector<double> one = ag::softmax(x, -1).to_vector();
    ag::set_num_threads(2);
    const std::vector<double> two = ag::softmax(x, -1).to_vector();
    ag::set_num_threads(1);
    ASSERT_EQ(one.size(), two.size());
    for (std::size_t i = 0; i < one.size(); ++i) ASSERT_EQ(one[i], two[i]) << "at " << i;

    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<double> masked = ag::softmax(tensor({0.0, -inf, -100.0, 0.0}, {1, 4}, dtype), -1).to_vector();
    EXPECT_EQ(masked[1], 0.0);
    EXPECT_LT(masked[2], 1e-40);
    EXPECT_NEAR(masked[0], 0.5, 1e-7);
    EXPECT_EQ(masked[0], masked[3]);
  }
}

}  // namespace
