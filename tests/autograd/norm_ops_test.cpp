// Group normalisation as one op (ops_norm.cpp): against each group standardised by hand, its one-pass rule against the
// rule in ops that create_graph records, gradcheck and gradgradcheck in float64, float32 against float64, and the
// refusals.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Tensor;
using agtest::expect_close;
using agtest::expect_grad_and_gradgrad;
using agtest::expect_throw_with;
using agtest::kF32;
using agtest::kF64;
using agtest::randn64;

TEST(GroupNorm, StandardisesEachGroupOfChannelsOverItsPositions) {
  const Tensor x = randn64({2, 6, 5}, 1, false) * 3.0 + 1.0;
  const Tensor y = ag::group_norm(x, 3, 1e-5);
  const auto xv = x.to_vector(), yv = y.to_vector();
  // Group g of row b: channels 2g and 2g + 1, 10 values contiguous in memory.
  for (std::int64_t start = 0; start < 60; start += 10) {
    double mean = 0.0, variance = 0.0;
    for (std::int64_t i = start; i < start + 10; ++i) mean += xv[i] / 10.0;
    for (std::int64_t i = start; i < start + 10; ++i) variance += (xv[i] - mean) * (xv[i] - mean) / 10.0;
    for (std::int64_t i = start; i < start + 10; ++i)
      EXPECT_NEAR(yv[i], (xv[i] - mean) / std::sqrt(variance + 1e-5), 1e-12) << "element " << i;
  }
  // Rank 2 (no positions) and rank 4 are groups of channels too.
  expect_close(ag::reshape(ag::group_norm(ag::reshape(x, {2, 6, 5, 1}), 3), {2, 6, 5}), y);
  EXPECT_EQ(ag::group_norm(ag::reshape(x, {2, 30}), 3).shape(), (ag::Shape{2, 30}));
}

TEST(GroupNorm, TheOnePassRuleIsTheRuleInOps) {
  const Tensor x = randn64({3, 4, 6}, 2), g = randn64({3, 4, 6}, 3, false);
  const Tensor one_pass = ag::grad({ag::group_norm(x, 2)}, {x}, {g})[0];
  const Tensor in_ops = ag::grad({ag::group_norm(x, 2)}, {x}, {g}, true, true)[0];
  EXPECT_TRUE(in_ops.requires_grad());
  expect_close(one_pass, in_ops.detach(), 1e-13);
}

TEST(GroupNorm, GradcheckAndGradgradcheck) {
  for (std::int64_t groups : {1, 2, 4}) {
    SCOPED_TRACE("groups " + std::to_string(groups));
    expect_grad_and_gradgrad("group_norm",
                             [groups](const std::vector<Tensor>& in) { return ag::group_norm(in[0], groups); },
                             {randn64({2, 4, 3}, 4)});
  }
}

TEST(GroupNorm, Float32AgreesWithFloat64) {
  const Tensor x = randn64({8, 24, 16}, 5, false);
  const Tensor single = ag::group_norm(x.to(kF32), 8);
  EXPECT_EQ(single.dtype(), kF32);
  expect_close(single.to(kF64), ag::group_norm(x, 8), 1e-5);
}

TEST(GroupNorm, RefusesWhatCannotBeMeant) {
  const Tensor x = ag::zeros({2, 6, 5}, kF64);
  expect_throw_with([&] { ag::group_norm(x, 4); }, {"group_norm", "6 channels do not split into 4 groups"});
  expect_throw_with([&] { ag::group_norm(x, 0); }, {"do not split into 0 groups"});
  expect_throw_with([&] { ag::group_norm(ag::zeros({6}, kF64), 3); }, {"expected x of shape [batch, channels, ...]"});
  expect_throw_with([&] { ag::group_norm(x, 3, 0.0); }, {"eps must be > 0"});
  expect_throw_with([&] { ag::group_norm(ag::zeros({0, 6, 5}, kF64), 3); }, {"is empty"});
}

}  // namespace
