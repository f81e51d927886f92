// The bfloat16 GEMM kernel (autograd/gemm_bf16.h, issue 44): its rounding to bfloat16, its products against double
// sums of the rounded operands (every storage order, tile remainders, odd inner sizes, inner blocks, accumulation),
// the same bits wherever a row or column falls, and its error against the float32 product within the bound the
// rounding gives. Skipped, saying why, on a CPU without AVX512-BF16.

#include "autograd/gemm_bf16.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <iostream>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace {

using maps::ag::detail::avx512_bf16_missing;
using maps::ag::detail::cpu_has_avx512_bf16;
using maps::ag::detail::gemm_bf16;
using maps::ag::detail::round_to_bf16;
using maps::ag::detail::StridedF32;

#define SKIP_WITHOUT_BF16()   \
  if (!cpu_has_avx512_bf16()) \
  GTEST_SKIP() << "this CPU lacks " << avx512_bf16_missing() << ": the bfloat16 kernel cannot run here"

TEST(RoundToBf16, RoundsToNearestEvenAndKeepsSpecialValues) {
  EXPECT_EQ(round_to_bf16(1.0f), 1.0f);
  EXPECT_EQ(round_to_bf16(-2.5f), -2.5f);
  // 1 + 2^-8 lies halfway between 1 and 1 + 2^-7 (bfloat16 keeps 7 mantissa bits): to the even one, 1.
  EXPECT_EQ(round_to_bf16(1.0f + std::ldexp(1.0f, -8)), 1.0f);
  // 1 + 3 * 2^-8 lies halfway between 1 + 2^-7 and 1 + 2^-6: to the even one, 1 + 2^-6.
  EXPECT_EQ(round_to_bf16(1.0f + 3.0f * std::ldexp(1.0f, -8)), 1.0f + std::ldexp(1.0f, -6));
  EXPECT_EQ(round_to_bf16(1.0f + std::ldexp(1.0f, -8) + std::ldexp(1.0f, -20)), 1.0f + std::ldexp(1.0f, -7));
  EXPECT_TRUE(std::isnan(round_to_bf16(std::numeric_limits<float>::quiet_NaN())));
  EXPECT_EQ(round_to_bf16(std::numeric_limits<float>::infinity()), std::numeric_limits<float>::infinity());
  std::mt19937 gen(3);
  std::normal_distribution<float> normal(0.0f, 10.0f);
  for (int i = 0; i < 10000; ++i) {
    const float x = normal(gen);
    EXPECT_LE(std::abs(round_to_bf16(x) - x), std::ldexp(std::abs(x), -8)) << x;  // half a unit in the last place
    EXPECT_EQ(round_to_bf16(round_to_bf16(x)), round_to_bf16(x));
  }
}

TEST(GemmBf16, TheCpuCheckNamesWhatIsMissing) {
  EXPECT_EQ(cpu_has_avx512_bf16(), avx512_bf16_missing().empty()) << avx512_bf16_missing();
  if (!cpu_has_avx512_bf16()) {
    float c = 0.0f, a = 1.0f, b = 1.0f;
    EXPECT_THROW(gemm_bf16({&a, 1, 1}, {&b, 1, 1}, &c, 1, 1, 1, 1, false), std::logic_error);
  }
}

struct Case {
  int m, n, k;
  bool ta, tb;  // the operand is stored transposed
};

struct Operands {
  std::vector<float> a, b;
  StridedF32 sa, sb;
};

Operands make(const Case& c, std::mt19937& gen) {
  std::normal_distribution<float> normal;
  Operands o;
  o.a.resize(static_cast<std::size_t>(c.m) * c.k);
  o.b.resize(static_cast<std::size_t>(c.k) * c.n);
  for (float& x : o.a) x = normal(gen);
  for (float& x : o.b) x = normal(gen);
  o.sa = c.ta ? StridedF32{o.a.data(), 1, c.m} : StridedF32{o.a.data(), c.k, 1};
  o.sb = c.tb ? StridedF32{o.b.data(), 1, c.k} : StridedF32{o.b.data(), c.n, 1};
  return o;
}

float at(const StridedF32& x, int i, int j) { return x.data[i * x.row_stride + j * x.col_stride]; }

std::vector<Case> cases() {
  std::vector<Case> all;
  for (int m : {1, 7, 8, 9, 17, 40})
    for (int n : {1, 5, 16, 31, 32, 33, 70})
      for (int k : {1, 2, 3, 17, 320, 321, 700})
        for (int t = 0; t < 4; ++t) all.push_back({m, n, k, (t & 1) != 0, (t & 2) != 0});
  return all;
}

TEST(GemmBf16, EqualsTheDoubleSumOfTheRoundedOperandsInEveryLayout) {
  SKIP_WITHOUT_BF16();
  std::mt19937 gen(1);
  for (const Case& c : cases())
    for (const bool accumulate : {false, true}) {
      Operands o = make(c, gen);
      const int ldc = c.n + 3;  // C's rows further apart than its width: the kernel must leave the gaps alone
      std::vector<float> start(static_cast<std::size_t>(c.m) * ldc);
      for (float& x : start) x = std::normal_distribution<float>()(gen);
      std::vector<float> out = start;
      gemm_bf16(o.sa, o.sb, out.data(), ldc, c.m, c.n, c.k, accumulate);
      double worst = 0.0;
      for (int i = 0; i < c.m; ++i)
        for (int j = 0; j < c.n; ++j) {
          double sum = accumulate ? start[i * ldc + j] : 0.0, size = std::abs(sum);
          for (int q = 0; q < c.k; ++q) {
            const double product = static_cast<double>(round_to_bf16(at(o.sa, i, q))) * round_to_bf16(at(o.sb, q, j));
            sum += product;
            size += std::abs(product);
          }
          worst = std::max(worst, std::abs(out[i * ldc + j] - sum) / size);
        }
      for (int i = 0; i < c.m; ++i)
        for (int j = c.n; j < ldc; ++j) ASSERT_EQ(out[i * ldc + j], start[i * ldc + j]);
      // Products of bfloat16 values are exact in float32: what is left is float32's summation, a few ulps.
      EXPECT_LT(worst, 2e-6) << c.m << "x" << c.n << "x" << c.k << (c.ta ? " A^T" : "") << (c.tb ? " B^T" : "")
                             << (accumulate ? " +=" : "");
    }
}

TEST(GemmBf16, GivesTheSameBitsWhereverARowOrColumnFalls) {
  SKIP_WITHOUT_BF16();
  std::mt19937 gen(2);
  for (const Case& c : {Case{300, 70, 700, false, false}, Case{100, 200, 321, true, true}}) {
    Operands o = make(c, gen);
    std::vector<float> whole(static_cast<std::size_t>(c.m) * c.n), parts(whole.size());
    gemm_bf16(o.sa, o.sb, whole.data(), c.n, c.m, c.n, c.k, false);
    // Rows [0, 13) and [13, m), then columns [0, 37) and [37, n) of each: four products of their own.
    for (const auto& [r0, r1] : {std::pair{0, 13}, std::pair{13, c.m}})
      for (const auto& [c0, c1] : {std::pair{0, 37}, std::pair{37, c.n}}) {
        const StridedF32 rows{o.sa.data + r0 * o.sa.row_stride, o.sa.row_stride, o.sa.col_stride};
        const StridedF32 cols{o.sb.data + c0 * o.sb.col_stride, o.sb.row_stride, o.sb.col_stride};
        gemm_bf16(rows, cols, parts.data() + r0 * c.n + c0, c.n, r1 - r0, c1 - c0, c.k, false);
      }
    EXPECT_EQ(whole, parts);
  }
}

TEST(GemmBf16, StaysWithinTheRoundingBoundOfTheFloat32Product) {
  SKIP_WITHOUT_BF16();
  std::mt19937 gen(4);
  const Case c{64, 48, 256, false, true};
  Operands o = make(c, gen);
  std::vector<float> out(static_cast<std::size_t>(c.m) * c.n);
  gemm_bf16(o.sa, o.sb, out.data(), c.n, c.m, c.n, c.k, false);
  double worst = 0.0, typical = 0.0;
  for (int i = 0; i < c.m; ++i)
    for (int j = 0; j < c.n; ++j) {
      double exact = 0.0, size = 0.0;
      for (int q = 0; q < c.k; ++q) {
        exact += static_cast<double>(at(o.sa, i, q)) * at(o.sb, q, j);
        size += std::abs(static_cast<double>(at(o.sa, i, q)) * at(o.sb, q, j));
      }
      const double error = std::abs(out[i * c.n + j] - exact) / size;
      worst = std::max(worst, error);
      typical += error / (c.m * c.n);
    }
  // Each operand is off by at most 2^-9 relatively, so each product by at most about 2^-8: the bound on the sum's
  // error relative to the sum of |products|. Random signs make the typical error far smaller.
  EXPECT_LT(worst, std::ldexp(1.0, -8) * 1.01);
  EXPECT_LT(typical, std::ldexp(1.0, -11));
  std::cout << "bf16 product error relative to sum |a b|: worst " << worst << ", mean " << typical << "\n";
}

}  // namespace
