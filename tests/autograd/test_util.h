#pragma once

// Shared helpers of the autograd tests: seeded float64 inputs kept away from the kinks of
// non-smooth ops, value comparisons, and gradcheck / gradgradcheck / error-message expectations
// that report at the caller's line.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <numeric>
#include <random>
#include <source_location>  // may define nothing (clang 14 with libstdc++ 12): see SourceLocation below
#include <string>
#include <vector>

#include "autograd/autograd.h"

namespace agtest {
// Where a helper was called from, for failure messages. clang 14 lacks __builtin_source_location, so its
// libstdc++ <source_location> is empty; that build (fuzz and sanitizer builds with clang) reports "?" instead.
#if defined(__cpp_lib_source_location)
using SourceLocation = std::source_location;
#else
struct SourceLocation {
  static constexpr SourceLocation current() noexcept { return {}; }
  constexpr const char* file_name() const noexcept { return "?"; }
  constexpr unsigned line() const noexcept { return 0; }
  constexpr const char* function_name() const noexcept { return "?"; }
};
#endif
}  // namespace agtest

namespace agtest {

namespace ag = maps::ag;
using ag::Dtype;
using ag::Shape;
using ag::Tensor;

inline constexpr Dtype kF32 = Dtype::Float32;
inline constexpr Dtype kF64 = Dtype::Float64;
inline constexpr Dtype kBothDtypes[] = {Dtype::Float32, Dtype::Float64};

// A tensor from row-major values (avoids the ambiguity of a braced list between the two from_vector overloads).
inline Tensor tensor(const std::vector<double>& values, const Shape& shape, Dtype dtype = kF64,
                     bool requires_grad = false) {
  Tensor t = ag::from_vector(values, shape, dtype);
  if (requires_grad) t.requires_grad_();
  return t;
}

// Standard-normal float64 tensor from `seed`, requiring grad by default.
inline Tensor randn64(const Shape& shape, std::uint64_t seed, bool requires_grad = true) {
  ag::Generator gen(seed);
  Tensor t = ag::randn(shape, gen, kF64);
  if (requires_grad) t.requires_grad_();
  return t;
}

// Uniform float64 tensor in [low, high) from `seed` (positive inputs for log, sqrt, pow, div).
inline Tensor uniform64(const Shape& shape, double low, double high, std::uint64_t seed, bool requires_grad = true) {
  ag::Generator gen(seed);
  Tensor t = ag::rand(shape, gen, kF64, low, high);
  if (requires_grad) t.requires_grad_();
  return t;
}

// Values with |x| in [low, high) and a random sign: away from the kink at 0 (abs, relu, division).
inline Tensor away_from_zero64(const Shape& shape, std::uint64_t seed, double low = 0.25, double high = 1.5,
                               bool requires_grad = true) {
  ag::Generator gen(seed);
  std::vector<double> values(static_cast<std::size_t>(ag::numel_of(shape)));
  for (double& v : values) {
    const double magnitude = gen.uniform(low, high);
    v = gen.uniform() < 0.5 ? -magnitude : magnitude;
  }
  return tensor(values, shape, kF64, requires_grad);
}

// Distinct multiples of `gap` around 0 (plus `offset`), in a random order: no ties (amax).
// With a half-gap `offset`, two such tensors never tie with each other either (minimum, maximum).
inline Tensor distinct64(const Shape& shape, std::uint64_t seed, double gap = 0.15, double offset = 0.0,
                         bool requires_grad = true) {
  const auto n = static_cast<std::size_t>(ag::numel_of(shape));
  std::vector<double> values(n);
  for (std::size_t i = 0; i < n; ++i) {
    values[i] = (static_cast<double>(i) - static_cast<double>(n / 2)) * gap + offset;
  }
  std::mt19937_64 engine(seed);
  std::shuffle(values.begin(), values.end(), engine);
  return tensor(values, shape, kF64, requires_grad);
}

// `base` plus or minus an offset of magnitude in [low, high): never ties with `base` (minimum, maximum).
inline Tensor offset_from64(const Tensor& base, std::uint64_t seed, double low = 0.2, double high = 1.0,
                            bool requires_grad = true) {
  Tensor offset = away_from_zero64(base.shape(), seed, low, high, false);
  std::vector<double> values = base.to_vector();
  for (std::size_t i = 0; i < values.size(); ++i) values[i] += offset.at(static_cast<std::int64_t>(i));
  return tensor(values, base.shape(), kF64, requires_grad);
}

// Values in (lo, hi) that stay at least `margin` away from each of the points in `kinks`.
inline Tensor avoiding64(const Shape& shape, double lo, double hi, const std::vector<double>& kinks, std::uint64_t seed,
                         double margin = 0.1, bool requires_grad = true) {
  ag::Generator gen(seed);
  std::vector<double> values(static_cast<std::size_t>(ag::numel_of(shape)));
  for (double& v : values) {
    bool ok = false;
    while (!ok) {
      v = gen.uniform(lo, hi);
      ok = std::none_of(kinks.begin(), kinks.end(), [&](double k) { return std::abs(v - k) < margin; });
    }
  }
  return tensor(values, shape, kF64, requires_grad);
}

// Reference NumPy broadcasting of an elementwise binary function over row-major values.
template <typename Fn>
std::vector<double> broadcast_ref(const std::vector<double>& a, const Shape& sa, const std::vector<double>& b,
                                  const Shape& sb, Fn fn, Shape* out_shape = nullptr) {
  const std::size_t rank = std::max(sa.size(), sb.size());
  Shape out(rank);
  Shape pa(rank, 1);
  Shape pb(rank, 1);
  std::copy(sa.begin(), sa.end(), pa.begin() + static_cast<std::ptrdiff_t>(rank - sa.size()));
  std::copy(sb.begin(), sb.end(), pb.begin() + static_cast<std::ptrdiff_t>(rank - sb.size()));
  for (std::size_t d = 0; d < rank; ++d) out[d] = std::max(pa[d], pb[d]);
  if (out_shape) *out_shape = out;
  std::vector<double> result(static_cast<std::size_t>(ag::numel_of(out)));
  std::vector<std::int64_t> index(rank, 0);
  for (std::size_t flat = 0; flat < result.size(); ++flat) {
    std::int64_t ia = 0;
    std::int64_t ib = 0;
    for (std::size_t d = 0; d < rank; ++d) {
      ia = ia * pa[d] + (pa[d] == 1 ? 0 : index[d]);
      ib = ib * pb[d] + (pb[d] == 1 ? 0 : index[d]);
    }
    result[flat] = fn(a[static_cast<std::size_t>(ia)], b[static_cast<std::size_t>(ib)]);
    for (std::size_t d = rank; d-- > 0;) {
      if (++index[d] < out[d]) break;
      index[d] = 0;
    }
  }
  return result;
}

inline double tolerance(Dtype dtype) { return dtype == kF32 ? 1e-5 : 1e-12; }

// Expects `actual` to have `shape` and the row-major `expected` values, to a relative-or-absolute tolerance.
inline void expect_values(const Tensor& actual, const Shape& shape, const std::vector<double>& expected,
                          double tol = 1e-12, SourceLocation loc = SourceLocation::current()) {
  ::testing::ScopedTrace trace(loc.file_name(), static_cast<int>(loc.line()), "expect_values");
  ASSERT_TRUE(actual.defined());
  ASSERT_EQ(ag::to_string(actual.shape()), ag::to_string(shape));
  ASSERT_EQ(actual.numel(), static_cast<std::int64_t>(expected.size()));
  const std::vector<double> got = actual.to_vector();
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_NEAR(got[i], expected[i], tol * std::max(1.0, std::abs(expected[i]))) << "element " << i;
  }
}

// Expects two tensors of the same shape with close values.
inline void expect_close(const Tensor& actual, const Tensor& expected, double tol = 1e-12,
                         SourceLocation loc = SourceLocation::current()) {
  ::testing::ScopedTrace trace(loc.file_name(), static_cast<int>(loc.line()), "expect_close");
  ASSERT_TRUE(actual.defined());
  ASSERT_TRUE(expected.defined());
  expect_values(actual, expected.shape(), expected.to_vector(), tol, loc);
}

// ----- gradcheck / gradgradcheck expectations -----

template <typename F>
void expect_check(const char* which, const std::string& op, F&& run, SourceLocation loc) {
  try {
    ag::GradcheckResult result = run();
    if (!result.ok) {
      ADD_FAILURE_AT(loc.file_name(), static_cast<int>(loc.line()))
          << which << " failed for " << op << ": " << result.message;
    }
  } catch (const std::exception& e) {
    ADD_FAILURE_AT(loc.file_name(), static_cast<int>(loc.line())) << which << " threw for " << op << ": " << e.what();
  }
}

inline void expect_gradcheck(const std::string& op, const ag::SingleFunction& f, const std::vector<Tensor>& inputs,
                             SourceLocation loc = SourceLocation::current()) {
  expect_check(
      "gradcheck", op, [&] { return ag::gradcheck(op, f, inputs); }, loc);
}

inline void expect_gradcheck(const std::string& op, const ag::MultiFunction& f, const std::vector<Tensor>& inputs,
                             SourceLocation loc = SourceLocation::current()) {
  expect_check(
      "gradcheck", op, [&] { return ag::gradcheck(op, f, inputs); }, loc);
}

inline void expect_gradgradcheck(const std::string& op, const ag::SingleFunction& f, const std::vector<Tensor>& inputs,
                                 SourceLocation loc = SourceLocation::current()) {
  expect_check(
      "gradgradcheck", op, [&] { return ag::gradgradcheck(op, f, inputs); }, loc);
}

inline void expect_gradgradcheck(const std::string& op, const ag::MultiFunction& f, const std::vector<Tensor>& inputs,
                                 SourceLocation loc = SourceLocation::current()) {
  expect_check(
      "gradgradcheck", op, [&] { return ag::gradgradcheck(op, f, inputs); }, loc);
}

// Both first and second derivatives.
inline void expect_grad_and_gradgrad(const std::string& op, const ag::SingleFunction& f,
                                     const std::vector<Tensor>& inputs,
                                     SourceLocation loc = SourceLocation::current()) {
  expect_gradcheck(op, f, inputs, loc);
  expect_gradgradcheck(op, f, inputs, loc);
}

// ----- error expectations -----

// Expects `fn` to throw a std::exception whose message contains every one of `needles`.
template <typename Fn>
void expect_throw_with(Fn&& fn, const std::vector<std::string>& needles,
                       SourceLocation loc = SourceLocation::current()) {
  try {
    fn();
  } catch (const std::exception& e) {
    const std::string message = e.what();
    for (const std::string& needle : needles) {
      if (message.find(needle) == std::string::npos) {
        ADD_FAILURE_AT(loc.file_name(), static_cast<int>(loc.line()))
            << "the error message does not contain \"" << needle << "\": " << message;
      }
    }
    return;
  }
  ADD_FAILURE_AT(loc.file_name(), static_cast<int>(loc.line())) << "expected an exception, none was thrown";
}

// The op name and both shapes, as error messages must name them.
inline std::vector<std::string> names(const std::string& op, const Shape& a, const Shape& b) {
  return {op, ag::to_string(a), ag::to_string(b)};
}

}  // namespace agtest
