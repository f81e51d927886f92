// The float32 GEMM kernel (autograd/gemm_f32.h) against plain double loops: every tile shape and remainder, both
// storage orders of both operands, inner blocks, narrow outputs, output strides, accumulation; and through ag::gemm,
// the same bits on one thread and two.

#include "autograd/gemm_f32.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "autograd/autograd.h"

namespace {

namespace ag = maps::ag;
using ag::detail::gemm_f32;
using ag::detail::StridedF32;

struct Product {
  std::int64_t m, n, k;
  bool ta, tb;
};

std::string describe(const Product& p, bool accumulate) {
  return std::to_string(p.m) + "x" + std::to_string(p.n) + "x" + std::to_string(p.k) + (p.ta ? " A^T" : "") +
         (p.tb ? " B^T" : "") + (accumulate ? " +=" : " =");
}

// Runs gemm_f32 on random operands stored as asked, C with 3 spare columns per row, and checks every element
// against the double sum within float32's bound (k ulps of the sum of |a b|); the spare columns must keep their
// sentinel, and without accumulate C's old NaNs must not leak in.
void check(const Product& p, bool accumulate, std::mt19937& rng) {
  SCOPED_TRACE(describe(p, accumulate));
  std::normal_distribution<float> normal;
  // The operands are stored with 2 spare NaN columns per row (as gemm_parallel's blocks of a larger matrix are):
  // reading one would poison the result.
  const std::int64_t a_rows = p.ta ? p.k : p.m, a_cols = p.ta ? p.m : p.k, lda = a_cols + 2;
  const std::int64_t b_rows = p.tb ? p.n : p.k, b_cols = p.tb ? p.k : p.n, ldb = b_cols + 2;
  std::vector<float> a(static_cast<std::size_t>(a_rows * lda)), b(static_cast<std::size_t>(b_rows * ldb));
  for (std::size_t i = 0; i < a.size(); ++i)
    a[i] = static_cast<std::int64_t>(i) % lda < a_cols ? normal(rng) : std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < b.size(); ++i)
    b[i] = static_cast<std::int64_t>(i) % ldb < b_cols ? normal(rng) : std::numeric_limits<float>::quiet_NaN();
  const std::int64_t ldc = p.n + 3;
  constexpr float kSentinel = 12345.0f;
  std::vector<float> c(static_cast<std::size_t>(p.m * ldc), kSentinel);
  std::vector<float> before(c.size());
  for (std::int64_t i = 0; i < p.m; ++i)
    for (std::int64_t j = 0; j < p.n; ++j)
      c[static_cast<std::size_t>(i * ldc + j)] = accumulate ? normal(rng) : std::numeric_limits<float>::quiet_NaN();
  before = c;

  const StridedF32 sa = p.ta ? StridedF32{a.data(), 1, lda} : StridedF32{a.data(), lda, 1};
  const StridedF32 sb = p.tb ? StridedF32{b.data(), 1, ldb} : StridedF32{b.data(), ldb, 1};
  gemm_f32(sa, sb, c.data(), ldc, p.m, p.n, p.k, accumulate);

  for (std::int64_t i = 0; i < p.m; ++i) {
    for (std::int64_t j = 0; j < ldc; ++j) {
      const std::size_t at = static_cast<std::size_t>(i * ldc + j);
      if (j >= p.n) {
        ASSERT_EQ(c[at], kSentinel) << "wrote past column " << p.n << " at (" << i << ", " << j << ")";
        continue;
      }
      double sum = accumulate ? before[at] : 0.0, magnitude = accumulate ? std::abs(before[at]) : 0.0;
      for (std::int64_t q = 0; q < p.k; ++q) {
        const double x = sa.data[i * sa.row_stride + q * sa.col_stride],
                     y = sb.data[q * sb.row_stride + j * sb.col_stride];
        sum += x * y;
        magnitude += std::abs(x * y);
      }
      const double tol = 2.0 * static_cast<double>(p.k + 1) * std::numeric_limits<float>::epsilon() * magnitude + 1e-30;
      ASSERT_NEAR(c[at], sum, tol) << "at (" << i << ", " << j << ")";
    }
  }
}

// The own kernels this build has and this CPU runs (AVX-512 and AVX2 on an AVX-512 CPU: every test runs both).
std::vector<ag::detail::F32Kernel> runnable_kernels() {
  std::vector<ag::detail::F32Kernel> out;
  for (const auto kernel : {ag::detail::F32Kernel::avx512, ag::detail::F32Kernel::avx2})
    if (ag::detail::f32_kernel_missing(kernel).empty()) out.push_back(kernel);
  return out;
}

// Runs `body` under each runnable own kernel, then restores the one in use.
template <typename Body>
void for_each_kernel(Body body) {
  const auto kernels = runnable_kernels();
  if (kernels.empty()) GTEST_SKIP() << "no own kernel runs here (neither AVX-512 nor AVX2); float32 runs Eigen's GEMM";
  for (const auto kernel : kernels) {
    SCOPED_TRACE(ag::detail::f32_kernel_name(kernel));
    const auto previous = ag::detail::set_f32_kernel(kernel);
    body();
    ag::detail::set_f32_kernel(previous);
  }
}

// The kernel is chosen at run time: the widest the CPU runs, or MAPS_F32_KERNEL's (CI's AVX2 pass sets it and checks
// the line printed here).
TEST(GemmF32, NamesTheKernelThisProcessRuns) {
  std::cout << "float32 GEMM kernel: " << ag::float32_gemm_kernel() << "\n";
  const char* named = std::getenv("MAPS_F32_KERNEL");
  const auto expected = named != nullptr && *named != '\0' ? ag::detail::parse_f32_kernel(named, "MAPS_F32_KERNEL")
                                                           : ag::detail::best_f32_kernel();
  EXPECT_STREQ(ag::float32_gemm_kernel(), ag::detail::f32_kernel_name(expected));
  // The widest the CPU runs, where this build has it.
#if defined(__GNUC__) && (defined(__x86_64__) || defined(_M_X64))
  if (ag::detail::f32_kernel_missing(ag::detail::F32Kernel::avx512).empty()) {
    EXPECT_EQ(ag::detail::best_f32_kernel(), ag::detail::F32Kernel::avx512);
    EXPECT_STREQ(ag::detail::f32_kernel_name(ag::detail::best_f32_kernel()), "maps AVX-512");
  }
#endif
}

TEST(GemmF32, AKernelNameOutsideTheChoicesOrOneTheCpuLacksIsRefusedByName) {
  EXPECT_THAT([] { ag::detail::parse_f32_kernel("sse", "MAPS_F32_KERNEL"); },
              ::testing::ThrowsMessage<std::invalid_argument>(
                  ::testing::HasSubstr("MAPS_F32_KERNEL: expected \"avx512\", \"avx2\" or \"eigen\", got \"sse\"")));
  for (const auto kernel : {ag::detail::F32Kernel::avx512, ag::detail::F32Kernel::avx2}) {
    const std::string missing = ag::detail::f32_kernel_missing(kernel);
    if (missing.empty()) continue;
    EXPECT_THAT([kernel] { ag::detail::set_f32_kernel(kernel); },
                ::testing::ThrowsMessage<std::runtime_error>(::testing::HasSubstr(missing)));
  }
  // Eigen's GEMM runs everywhere.
  const auto previous = ag::detail::set_f32_kernel(ag::detail::F32Kernel::eigen);
  EXPECT_STREQ(ag::float32_gemm_kernel(), "Eigen");
  ag::detail::set_f32_kernel(previous);
}

// Both instruction sets sum each element in the same order, so AVX2 and AVX-512 give the same bits: a run's results
// do not depend on which of them the CPU picked.
TEST(GemmF32, EveryKernelGivesTheSameBits) {
  const auto kernels = runnable_kernels();
  if (kernels.size() < 2) GTEST_SKIP() << "fewer than two own kernels run on this CPU";
  ag::Generator gen(12);
  struct Sizes {
    std::int64_t m, n, k;
  };
  for (const Sizes s : {Sizes{640, 128, 17}, Sizes{128, 128, 640}, Sizes{320, 10, 128}, Sizes{33, 9, 700},
                        Sizes{300, 260, 700}, Sizes{7, 47, 321}})
    for (const bool ta : {false, true})
      for (const bool tb : {false, true}) {
        const ag::Tensor a = ag::randn(ta ? ag::Shape{s.k, s.m} : ag::Shape{s.m, s.k}, gen);
        const ag::Tensor b = ag::randn(tb ? ag::Shape{s.n, s.k} : ag::Shape{s.k, s.n}, gen);
        std::vector<std::vector<double>> results;
        for (const auto kernel : kernels) {
          const auto previous = ag::detail::set_f32_kernel(kernel);
          results.push_back(ag::gemm(a, b, ta, tb).to_vector());
          ag::detail::set_f32_kernel(previous);
        }
        for (std::size_t r = 1; r < results.size(); ++r)
          for (std::size_t i = 0; i < results[0].size(); ++i)
            ASSERT_EQ(results[0][i], results[r][i])
                << s.m << "x" << s.n << "x" << s.k << " ta " << ta << " tb " << tb << " at " << i;
      }
}

TEST(GemmF32, EveryTileShapeAndRemainderMatchesPlainLoops) {
  for_each_kernel([] {
    std::mt19937 rng(7);
    // Rows around the tiles (AVX-512: 8 and 12 rows; AVX2: 6 and 8), columns around the panels (32 and 16; 16 and 8),
    // inner sizes within one block, exactly one, and split in equal blocks (321 -> 2 x 161).
    for (const std::int64_t m : {1, 5, 6, 7, 8, 9, 13, 24, 33})
      for (const std::int64_t n : {1, 4, 8, 9, 10, 16, 17, 32, 33, 47})
        for (const std::int64_t k : {1, 5, 33, 321})
          for (const bool ta : {false, true})
            for (const bool tb : {false, true})
              for (const bool accumulate : {false, true}) check({m, n, k, ta, tb}, accumulate, rng);
  });
}

TEST(GemmF32, TrainingStepShapesMatchPlainLoops) {
  for_each_kernel([] {
    std::mt19937 rng(8);
    // Past the 256-row and 256-column chunks and several inner blocks; the narrow outputs of a policy head and the
    // selector's scores in both orientations; MT10's first layer (39 inputs) and its weight gradient.
    const std::vector<Product> products = {
        {300, 260, 700, false, false}, {260, 300, 700, true, true}, {520, 10, 128, false, true},
        {128, 10, 900, true, false},   {128, 4, 320, true, false},  {320, 128, 4, false, true},
        {320, 128, 39, false, false},  {39, 128, 320, true, false}, {40, 6, 64, true, true},
        {300, 10, 50, true, false},    {270, 16, 700, true, true},
    };
    for (const Product& p : products)
      for (const bool accumulate : {false, true}) check(p, accumulate, rng);
  });
}

TEST(GemmF32, EmptyInnerDimensionZeroesOrKeepsTheOutput) {
  for_each_kernel([] {
    std::vector<float> c(2 * 5, 3.0f);
    const float none = 0.0f;
    gemm_f32({&none, 0, 1}, {&none, 3, 1}, c.data(), 5, 2, 3, 0, /*accumulate=*/true);
    for (std::size_t i = 0; i < c.size(); ++i) EXPECT_EQ(c[i], 3.0f) << i;
    gemm_f32({&none, 0, 1}, {&none, 3, 1}, c.data(), 5, 2, 3, 0, /*accumulate=*/false);
    for (std::size_t i = 0; i < c.size(); ++i) EXPECT_EQ(c[i], i % 5 < 3 ? 0.0f : 3.0f) << i;
    gemm_f32({&none, 0, 1}, {&none, 0, 1}, c.data(), 5, 0, 3, 4, false);  // no rows: nothing read or written
  });
}

// Each output element is summed in the same order wherever gemm_parallel's split puts its tile: split by rows
// (taller than wide) and by columns (wider than tall, the parts of a transposed-A product then narrow enough for
// the narrow path).
TEST(GemmF32, OneAndTwoThreadsGiveTheSameBits) {
  for_each_kernel([] {
    ag::Generator gen(11);
    struct Sizes {
      std::int64_t m, n, k;
    };
    for (const Sizes s : {Sizes{300, 140, 330}, Sizes{40, 300, 330}, Sizes{20, 2000, 640}})
      for (const bool ta : {false, true})
        for (const bool tb : {false, true}) {
          const ag::Tensor a = ag::randn(ta ? ag::Shape{s.k, s.m} : ag::Shape{s.m, s.k}, gen);
          const ag::Tensor b = ag::randn(tb ? ag::Shape{s.n, s.k} : ag::Shape{s.k, s.n}, gen);
          const std::vector<double> one = ag::gemm(a, b, ta, tb).to_vector();
          ag::set_num_threads(2);
          const std::vector<double> two = ag::gemm(a, b, ta, tb).to_vector();
          ag::set_num_threads(1);
          ASSERT_EQ(one.size(), two.size());
          for (std::size_t i = 0; i < one.size(); ++i)
            ASSERT_EQ(one[i], two[i]) << s.m << "x" << s.n << "x" << s.k << " ta " << ta << " tb " << tb << " at " << i;
        }
  });
}

}  // namespace
