// Reductions: sum, mean and amax, over everything or over dims, with and without keepdim.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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
using agtest::tensor;

enum class Kind { Sum, Mean, Amax };

const char* kind_name(Kind k) { return k == Kind::Sum ? "sum" : k == Kind::Mean ? "mean" : "amax"; }

// Reference reduction of row-major `values` of `shape` over `dims` (normalised, any order).
std::vector<double> reduce_ref(const std::vector<double>& values, const Shape& shape, std::vector<std::int64_t> dims,
                               bool keepdim, Kind kind, Shape* out_shape) {
  const auto rank = static_cast<std::int64_t>(shape.size());
  std::vector<bool> reduced(shape.size(), false);
  for (std::int64_t d : dims) reduced[static_cast<std::size_t>(d < 0 ? d + rank : d)] = true;
  Shape out;
  Shape kept(shape.size());
  for (std::size_t d = 0; d < shape.size(); ++d) {
    kept[d] = reduced[d] ? 1 : shape[d];
    if (!reduced[d])
      out.push_back(shape[d]);
    else if (keepdim)
      out.push_back(1);
  }
  *out_shape = out;
  const auto n_out = static_cast<std::size_t>(ag::numel_of(kept));
  std::vector<double> acc(n_out, kind == Kind::Amax ? -std::numeric_limits<double>::infinity() : 0.0);
  std::vector<std::int64_t> count(n_out, 0);
  std::vector<std::int64_t> index(shape.size(), 0);
  for (std::size_t flat = 0; flat < values.size(); ++flat) {
    std::int64_t o = 0;
    for (std::size_t d = 0; d < shape.size(); ++d) o = o * kept[d] + (reduced[d] ? 0 : index[d]);
    auto& a = acc[static_cast<std::size_t>(o)];
    a = kind == Kind::Amax ? std::max(a, values[flat]) : a + values[flat];
    ++count[static_cast<std::size_t>(o)];
    for (std::size_t d = shape.size(); d-- > 0;) {
      if (++index[d] < shape[d]) break;
      index[d] = 0;
    }
  }
  if (kind == Kind::Mean) {
    for (std::size_t i = 0; i < n_out; ++i) acc[i] /= static_cast<double>(count[i]);
  }
  return acc;
}

Tensor reduce(Kind kind, const Tensor& x, const std::vector<std::int64_t>& dims, bool keepdim) {
  switch (kind) {
    case Kind::Sum:
      return ag::sum(x, dims, keepdim);
    case Kind::Mean:
      return ag::mean(x, dims, keepdim);
    default:
      return ag::amax(x, dims, keepdim);
  }
}

Tensor reduce_all(Kind kind, const Tensor& x) {
  switch (kind) {
    case Kind::Sum:
      return ag::sum(x);
    case Kind::Mean:
      return ag::mean(x);
    default:
      return ag::amax(x);
  }
}

// Distinct values everywhere, so amax has no ties and every input is a smooth point.
Tensor input_for(Kind kind, const Shape& shape, std::uint64_t seed) {
  return kind == Kind::Amax ? agtest::distinct64(shape, seed, 0.15) : agtest::randn64(shape, seed);
}

struct DimsCase {
  Shape shape;
  std::vector<std::int64_t> dims;
};

const std::vector<DimsCase> kDimsCases = {
    {{5}, {0}},           {{5}, {-1}},         {{2, 3}, {0}},          {{2, 3}, {1}},    {{2, 3}, {-1}},
    {{2, 3}, {0, 1}},     {{2, 3, 4}, {0}},    {{2, 3, 4}, {1}},       {{2, 3, 4}, {2}}, {{2, 3, 4}, {0, 2}},
    {{2, 3, 4}, {-1, 0}}, {{2, 3, 4}, {1, 2}}, {{2, 3, 4}, {0, 1, 2}},
};

std::string case_name(const DimsCase& c, bool keepdim) {
  std::string s = ag::to_string(c.shape) + " dims " + ag::to_string(c.dims);
  return s + (keepdim ? " keepdim" : "");
}

class ReductionTest : public ::testing::TestWithParam<Kind> {};

TEST_P(ReductionTest, ForwardOverEverything) {
  const Kind kind = GetParam();
  std::uint64_t seed = 1;
  for (const Shape& shape : {Shape{}, Shape{5}, Shape{2, 3}, Shape{2, 3, 4}}) {
    for (Dtype dtype : kBothDtypes) {
      SCOPED_TRACE(ag::to_string(shape) + " " + ag::to_string(dtype));
      const Tensor x = input_for(kind, shape, seed++).detach().to(dtype);
      std::vector<std::int64_t> all(shape.size());
      for (std::size_t d = 0; d < shape.size(); ++d) all[d] = static_cast<std::int64_t>(d);
      Shape out_shape;
      const std::vector<double> expected = reduce_ref(x.to_vector(), shape, all, false, kind, &out_shape);
      const Tensor y = reduce_all(kind, x);
      EXPECT_EQ(y.dtype(), dtype);
      expect_values(y, {}, expected, agtest::tolerance(dtype) * 10);
    }
  }
}

TEST_P(ReductionTest, ForwardOverDims) {
  const Kind kind = GetParam();
  std::uint64_t seed = 50;
  for (const DimsCase& c : kDimsCases) {
    for (bool keepdim : {false, true}) {
      for (Dtype dtype : kBothDtypes) {
        SCOPED_TRACE(case_name(c, keepdim) + " " + ag::to_string(dtype));
        const Tensor x = input_for(kind, c.shape, seed++).detach().to(dtype);
        Shape out_shape;
        const std::vector<double> expected = reduce_ref(x.to_vector(), c.shape, c.dims, keepdim, kind, &out_shape);
        const Tensor y = reduce(kind, x, c.dims, keepdim);
        EXPECT_EQ(y.dtype(), dtype);
        expect_values(y, out_shape, expected, agtest::tolerance(dtype) * 10);
      }
    }
  }
}

TEST_P(ReductionTest, GradcheckOverEverything) {
  const Kind kind = GetParam();
  std::uint64_t seed = 100;
  for (const Shape& shape : {Shape{}, Shape{5}, Shape{2, 3}, Shape{2, 3, 4}}) {
    SCOPED_TRACE(ag::to_string(shape));
    auto f = [kind](const std::vector<Tensor>& in) { return reduce_all(kind, in[0]); };
    agtest::expect_gradcheck(kind_name(kind), f, {input_for(kind, shape, seed++)});
  }
}

TEST_P(ReductionTest, GradcheckOverDims) {
  const Kind kind = GetParam();
  std::uint64_t seed = 200;
  for (const DimsCase& c : kDimsCases) {
    for (bool keepdim : {false, true}) {
      SCOPED_TRACE(case_name(c, keepdim));
      auto f = [kind, dims = c.dims, keepdim](const std::vector<Tensor>& in) {
        return reduce(kind, in[0], dims, keepdim);
      };
      agtest::expect_gradcheck(kind_name(kind), f, {input_for(kind, c.shape, seed++)});
    }
  }
}

TEST_P(ReductionTest, Gradgradcheck) {
  const Kind kind = GetParam();
  std::uint64_t seed = 300;
  auto all = [kind](const std::vector<Tensor>& in) { return reduce_all(kind, in[0]); };
  agtest::expect_gradgradcheck(kind_name(kind), all, {input_for(kind, {2, 3}, seed++)});
  for (const DimsCase& c : {DimsCase{{2, 3}, {1}}, DimsCase{{2, 3, 4}, {0, 2}}}) {
    for (bool keepdim : {false, true}) {
      SCOPED_TRACE(case_name(c, keepdim));
      auto f = [kind, dims = c.dims, keepdim](const std::vector<Tensor>& in) {
        return reduce(kind, in[0], dims, keepdim);
      };
      agtest::expect_gradgradcheck(kind_name(kind), f, {input_for(kind, c.shape, seed++)});
    }
  }
  // Squared, so the second derivative is not zero.
  auto sq = [kind](const std::vector<Tensor>& in) { return ag::square(reduce(kind, in[0], {0}, false)); };
  agtest::expect_gradgradcheck(kind_name(kind), sq, {input_for(kind, {3, 2}, seed++)});
}

TEST_P(ReductionTest, BadDimNamesOp) {
  const Kind kind = GetParam();
  const Tensor x = ag::ones({2, 3}, kF64);
  expect_throw_with([&] { reduce(kind, x, {2}, false); }, {kind_name(kind)});
  expect_throw_with([&] { reduce(kind, x, {-3}, true); }, {kind_name(kind)});
  expect_throw_with([&] { reduce(kind, ag::ones({4}, kF64), {1}, false); }, {kind_name(kind)});
}

INSTANTIATE_TEST_SUITE_P(AllReductions, ReductionTest, ::testing::Values(Kind::Sum, Kind::Mean, Kind::Amax),
                         [](const ::testing::TestParamInfo<Kind>& info) { return std::string(kind_name(info.param)); });

// ----- hand-computed values -----

TEST(Reductions, HandComputedValues) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor x = tensor({1, 5, 3, 4, 2, 6}, {2, 3}, dtype);
    expect_values(ag::sum(x), {}, {21});
    expect_values(ag::mean(x), {}, {3.5});
    expect_values(ag::amax(x), {}, {6});
    expect_values(ag::sum(x, {0}), {3}, {5, 7, 9});
    expect_values(ag::sum(x, {1}, true), {2, 1}, {9, 12});
    expect_values(ag::mean(x, {0}, true), {1, 3}, {2.5, 3.5, 4.5});
    expect_values(ag::mean(x, {-1}), {2}, {3, 4});
    expect_values(ag::amax(x, {0}), {3}, {4, 5, 6});
    expect_values(ag::amax(x, {1}, true), {2, 1}, {5, 6});
    expect_values(ag::sum(x, {0, 1}), {}, {21});
    expect_values(ag::amax(tensor({-3, -1, -2}, {3}, dtype)), {}, {-1});
  }
}

TEST(Reductions, HandComputedGradients) {
  const Tensor x = tensor({1, 5, 3, 4, 2, 6}, {2, 3}, kF64, true);
  ag::sum(ag::mean(x, {1})).backward();
  expect_values(x.grad(), {2, 3}, std::vector<double>(6, 1.0 / 3));
  const Tensor y = tensor({1, 5, 3, 4, 2, 6}, {2, 3}, kF64, true);
  ag::sum(ag::amax(y, {0})).backward();
  expect_values(y.grad(), {2, 3}, {0, 1, 0, 1, 0, 1});
  const Tensor z = tensor({1, 2, 3, 4}, {2, 2}, kF64, true);
  ag::mean(z).backward();
  expect_values(z.grad(), {2, 2}, {0.25, 0.25, 0.25, 0.25});
}

TEST(Reductions, AmaxTiesShareGradientEvenly) {
  const Tensor x = tensor({1, 3, 3}, {3}, kF64, true);
  ag::amax(x).backward();
  expect_values(x.grad(), {3}, {0, 0.5, 0.5});
  const Tensor y = tensor({2, 2, 2, 1, 0, 1}, {2, 3}, kF64, true);
  ag::sum(ag::amax(y, {1})).backward();
  expect_values(y.grad(), {2, 3}, {1.0 / 3, 1.0 / 3, 1.0 / 3, 0.5, 0, 0.5});
}

TEST(Reductions, CompositeGradgradcheck) {
  // A variance: mean of squared deviations from the mean.
  auto variance = [](const std::vector<Tensor>& in) {
    const Tensor centred = in[0] - ag::mean(in[0], {1}, true);
    return ag::mean(ag::square(centred), {1});
  };
  expect_grad_and_gradgrad("variance", variance, {agtest::randn64({3, 4}, 7)});
}

}  // namespace
