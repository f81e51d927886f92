// In-place changes of tensors a graph saved (issue 15): PyTorch refuses the backward pass; so must we.

#include <gtest/gtest.h>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Tensor;
using agtest::expect_throw_with;
using agtest::expect_values;
using agtest::kF32;
using agtest::kF64;
using agtest::tensor;

TEST(InPlace, ChangingAnInputAMulSavedMakesBackwardThrow) {
  Tensor w = tensor({1, 2}, {2}, kF64, true);
  const Tensor loss = ag::sum(w * w);
  w.detach().copy_(tensor({3, 4}, {2}));  // would give [6, 8] instead of [2, 4]
  expect_throw_with([&] { loss.backward(); },
                    {"input 0 of 'mul'", "[2] float64", "changed in place", "version 1, saved at 0"});
}

TEST(InPlace, ChangingASavedOutputMakesBackwardThrow) {
  const Tensor x = tensor({0.5, -1.0}, {2}, kF32, true);
  Tensor y = ag::exp(x);
  const Tensor l = ag::sum(y);
  y.fill_(0.0);  // would give a zero gradient
  expect_throw_with([&] { l.backward(); }, {"the output of 'exp'", "changed in place"});
}

TEST(InPlace, AViewSharesTheCountOfItsStorage) {
  Tensor w = tensor({1, 2, 3, 4}, {2, 2}, kF64, true);
  const Tensor r = w.reshape({4});
  const Tensor loss = ag::sum(r * r);
  w.detach().fill_(1.0);
  expect_throw_with([&] { loss.backward(); }, {"'mul'", "changed in place"});
}

// An op whose rule reads no values (add, sum, reshape, ...) does not care, as in PyTorch.
TEST(InPlace, OpsThatReadNoValuesAllowTheChange) {
  Tensor x = tensor({1, 2}, {2}, kF64, true);
  const Tensor loss = ag::sum(ag::add(x, 1.0) + x.reshape({2}));
  x.detach().fill_(7.0);
  loss.backward();
  expect_values(x.grad(), {2}, {2, 2});
}

// where() routes the gradient by its condition: a later change of the condition must not reroute it.
TEST(InPlace, WhereKeepsItsOwnCondition) {
  Tensor condition = tensor({1, 0}, {2});
  const Tensor a = tensor({1, 2}, {2}, kF64, true);
  const Tensor b = tensor({3, 4}, {2}, kF64, true);
  const Tensor loss = ag::sum(ag::where(condition, a, b));
  condition.fill_(0.0);
  loss.backward();
  expect_values(a.grad(), {2}, {1, 0});
  expect_values(b.grad(), {2}, {0, 1});
}

TEST(InPlace, CopyAndFillCountEveryChangeAndTheCountIsShared) {
  Tensor x = tensor({1, 2}, {2});
  EXPECT_EQ(x.version(), 0u);
  x.fill_(3.0);
  x.copy_(tensor({5, 6}, {2}));
  const Tensor view = x.detach();
  EXPECT_EQ(view.version(), 2u);
  view.detach().bump_version();
  EXPECT_EQ(x.version(), 3u);
}

TEST(InPlace, ASecondOrderGraphSeesTheChangeToo) {
  Tensor x = tensor({0.3, -0.7}, {2}, kF64, true);
  const Tensor y = ag::sum(ag::tanh(x) * x);
  const Tensor g = ag::grad({y}, {x}, {}, /*retain_graph=*/true, /*create_graph=*/true)[0];
  x.detach().fill_(0.0);
  expect_throw_with([&] { ag::sum(g).backward(); }, {"changed in place"});
}

}  // namespace
