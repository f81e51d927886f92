// Losses and encodings: mse_loss and one_hot.

#include <gtest/gtest.h>

#include <cstdint>
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
using agtest::kF32;
using agtest::kF64;
using agtest::randn64;
using agtest::tensor;

using Inputs = std::vector<Tensor>;

TEST(MseLoss, ForwardMatchesReference) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor p = tensor({1, 2, 3, 4}, {2, 2}, dtype);
    const Tensor t = tensor({0, 2, 5, 3}, {2, 2}, dtype);
    const Tensor loss = ag::mse_loss(p, t);
    EXPECT_EQ(loss.dtype(), dtype);
    expect_values(loss, {}, {(1 + 0 + 4 + 1) / 4.0}, agtest::tolerance(dtype));
    std::uint64_t seed = 1;
    for (const Shape& shape : {Shape{5}, Shape{2, 3}, Shape{2, 3, 4}, Shape{}}) {
      SCOPED_TRACE(ag::to_string(shape));
      const Tensor a = randn64(shape, seed++, false).to(dtype);
      const Tensor b = randn64(shape, seed++, false).to(dtype);
      double expected = 0;
      const std::vector<double> av = a.to_vector(), bv = b.to_vector();
      for (std::size_t i = 0; i < av.size(); ++i) expected += (av[i] - bv[i]) * (av[i] - bv[i]);
      expected /= static_cast<double>(av.size());
      expect_values(ag::mse_loss(a, b), {}, {expected}, agtest::tolerance(dtype) * 10);
    }
  }
}

TEST(MseLoss, HandComputedGradients) {
  const Tensor p = tensor({1, 2, 3, 4}, {2, 2}, kF64, true);
  const Tensor t = tensor({0, 2, 5, 3}, {2, 2}, kF64, true);
  ag::mse_loss(p, t).backward();
  // d/dp = 2 (p - t) / n, d/dt = -2 (p - t) / n.
  expect_values(p.grad(), {2, 2}, {0.5, 0, -1, 0.5});
  expect_values(t.grad(), {2, 2}, {-0.5, 0, 1, -0.5});
}

TEST(MseLoss, GradcheckAndGradgradcheck) {
  std::uint64_t seed = 10;
  for (const Shape& shape : {Shape{4}, Shape{2, 3}, Shape{2, 3, 2}, Shape{}}) {
    SCOPED_TRACE(ag::to_string(shape));
    auto f = [](const Inputs& in) { return ag::mse_loss(in[0], in[1]); };
    expect_grad_and_gradgrad("mse_loss", f, {randn64(shape, seed++), randn64(shape, seed++)});
    // A fixed target, as in training.
    expect_grad_and_gradgrad("mse_loss", f, {randn64(shape, seed++), randn64(shape, seed++, false)});
  }
}

TEST(MseLoss, RegressionCompositeGradgradcheck) {
  // mse of a linear model's prediction: the loss nn's tests and MAML's inner step use.
  const Tensor target = randn64({3, 2}, 4, false);
  auto model = [target](const Inputs& in) { return ag::mse_loss(ag::matmul(in[0], in[1]) + in[2], target); };
  expect_grad_and_gradgrad("linear mse", model, {randn64({3, 2}, 1), randn64({2, 2}, 2), randn64({2}, 3)});
}

TEST(OneHot, Values) {
  for (Dtype dtype : kBothDtypes) {
    SCOPED_TRACE(ag::to_string(dtype));
    const Tensor y = ag::one_hot({2, 0, 1, 2}, 3, dtype);
    EXPECT_EQ(y.dtype(), dtype);
    expect_values(y, {4, 3}, {0, 0, 1, 1, 0, 0, 0, 1, 0, 0, 0, 1});
    EXPECT_FALSE(y.requires_grad());
    EXPECT_EQ(y.grad_fn(), nullptr);
  }
  EXPECT_EQ(ag::one_hot({0}, 1).dtype(), kF32);  // float32 by default
  expect_values(ag::one_hot({0}, 1), {1, 1}, {1});
  expect_values(ag::one_hot({4}, 5), {1, 5}, {0, 0, 0, 0, 1});
}

TEST(OneHot, IndexOutOfRangeNamesOp) {
  expect_throw_with([] { ag::one_hot({0, 3}, 3); }, {"one_hot", "3"});
  expect_throw_with([] { ag::one_hot({-1}, 3); }, {"one_hot"});
  expect_throw_with([] { ag::one_hot({0}, 0); }, {"one_hot"});
}

TEST(MseLoss, ShapeMismatchNamesOp) {
  // Different numbers of elements can never be a per-element loss.
  expect_throw_with([] { ag::mse_loss(ag::ones({2, 3}), ag::ones({4})); }, agtest::names("mse_loss", {2, 3}, {4}));
  expect_throw_with([] { ag::mse_loss(ag::ones({2}, kF32), ag::ones({2}, kF64)); }, {"mse_loss"});
}

}  // namespace
