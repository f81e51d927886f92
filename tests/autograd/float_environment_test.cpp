// Flushing denormal floats to zero (autograd/float_environment.h): on and off per thread, restored by the guard,
// followed by parallel_for's threads, and what it changes in ops (products below float's smallest normal) and what
// it leaves alone (everything else, bit for bit).
#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <vector>

#include "autograd/autograd.h"

namespace {

namespace ag = maps::ag;

// 1e-20 * 1e-20 = 1e-40: below float's smallest normal (1.18e-38), a denormal unless flushed. volatile: computed
// now, under the mode in force, not folded by the compiler.
float denormal_product() {
  volatile float a = 1e-20f;
  volatile float b = 1e-20f;
  return a * b;
}

class FlushDenormal : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!ag::flush_denormal_supported()) GTEST_SKIP() << "this CPU cannot flush denormals";
    previous_ = ag::set_flush_denormal(false);
  }
  void TearDown() override {
    ag::set_flush_denormal(previous_);
    ag::set_num_threads(1);
  }
  bool previous_ = false;
};

TEST_F(FlushDenormal, OnFlushesAndOffKeepsTheDenormal) {
  EXPECT_FALSE(ag::flush_denormal());
  EXPECT_GT(denormal_product(), 0.0f);
  EXPECT_FALSE(ag::set_flush_denormal(true));
  EXPECT_TRUE(ag::flush_denormal());
  EXPECT_EQ(denormal_product(), 0.0f);
  // Denormal inputs are read as zero too (DAZ): a denormal times a large number stays 0.
  volatile float denormal = std::numeric_limits<float>::denorm_min();
  volatile float large = 1e30f;
  EXPECT_EQ(denormal * large, 0.0f);
  EXPECT_TRUE(ag::set_flush_denormal(false));
  EXPECT_GT(denormal * large, 0.0f);
}

TEST_F(FlushDenormal, TheGuardRestoresTheModeItFound) {
  {
    const ag::FlushDenormalGuard guard;
    EXPECT_TRUE(ag::flush_denormal());
    {
      const ag::FlushDenormalGuard off(false);
      EXPECT_FALSE(ag::flush_denormal());
    }
    EXPECT_TRUE(ag::flush_denormal());
  }
  EXPECT_FALSE(ag::flush_denormal());
}

TEST_F(FlushDenormal, ParallelForThreadsComputeAsTheCallerDoes) {
  ag::set_num_threads(2);
  for (const bool on : {true, false, true}) {
    const ag::FlushDenormalGuard guard(on);
    std::vector<float> products(64, -1.0f);
    ag::parallel_for_ranges(64, 2, [&](std::int64_t, std::int64_t begin, std::int64_t end) {
      for (std::int64_t i = begin; i < end; ++i) products[static_cast<std::size_t>(i)] = denormal_product();
    });
    for (const float p : products) {
      if (on)
        EXPECT_EQ(p, 0.0f);
      else
        EXPECT_GT(p, 0.0f);
    }
  }
}

TEST_F(FlushDenormal, OpsFlushOnlyWhatIsBelowTheSmallestNormal) {
  const ag::Tensor tiny = ag::from_vector(std::vector<float>{1e-20f, 1e-19f, 0.5f, 3.0f}, {4});
  const ag::Tensor scale = ag::from_vector(std::vector<float>{1e-20f, 1e-25f, 0.25f, -2.0f}, {4});
  const std::vector<double> kept = (tiny * scale).to_vector();
  EXPECT_GT(kept[0], 0.0);
  EXPECT_GT(kept[1], 0.0);
  const ag::FlushDenormalGuard guard;
  const std::vector<double> flushed = (tiny * scale).to_vector();
  EXPECT_EQ(flushed[0], 0.0);
  EXPECT_EQ(flushed[1], 0.0);
  EXPECT_EQ(flushed[2], kept[2]);
  EXPECT_EQ(flushed[3], kept[3]);
  // A GEMM of normal numbers gives the same bits either way (run on 2 threads as well).
  std::vector<float> a(64 * 48), b(48 * 32);
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = static_cast<float>((i * 37 % 101) - 50) / 17.0f;
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = static_cast<float>((i * 53 % 89) - 44) / 13.0f;
  const ag::Tensor ta = ag::from_vector(a, {64, 48}), tb = ag::from_vector(b, {48, 32});
  const std::vector<double> with_flush = ag::matmul(ta, tb).to_vector();
  ag::set_num_threads(2);
  const std::vector<double> two_threads = ag::matmul(ta, tb).to_vector();
  ag::set_flush_denormal(false);
  EXPECT_EQ(ag::matmul(ta, tb).to_vector(), with_flush);
  EXPECT_EQ(two_threads, with_flush);
}

}  // namespace
