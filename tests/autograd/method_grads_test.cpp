// First and second derivatives of the Tensor methods and of the ops the other files check only to first order
// (issue 15, item 3): Tensor::to, transpose() and t(), reshape(), slice, and mlp with an activation on its last layer.
// Each function multiplies the op's result by something that depends on the input, so the second derivative is
// not trivially zero.

#include <gtest/gtest.h>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Fused;
using ag::Tensor;
using agtest::expect_grad_and_gradgrad;
using agtest::kF32;
using agtest::kF64;
using agtest::randn64;

using Inputs = std::vector<Tensor>;

TEST(MethodGradients, TransposeAndT) {
  const Tensor x = randn64({3, 4}, 1);
  expect_grad_and_gradgrad("transpose()", [](const Inputs& in) { return in[0].transpose(0, 1) * in[0].t(); }, {x});
  const Tensor y = randn64({2, 3, 4}, 2);
  expect_grad_and_gradgrad("transpose(-1, 0)",
                           [](const Inputs& in) { return ag::tanh(in[0].transpose(-1, 0)) * in[0].transpose(2, 0); },
                           {y});
  expect_grad_and_gradgrad("t()", [](const Inputs& in) { return ag::matmul(in[0].t(), in[0]); }, {x});
}

TEST(MethodGradients, Reshape) {
  const Tensor x = randn64({2, 6}, 3);
  expect_grad_and_gradgrad("reshape()",
                           [](const Inputs& in) {
                             return in[0].reshape({3, 4}) * in[0].reshape({-1, 4});
                           },
                           {x});
  expect_grad_and_gradgrad("reshape() to a scalar",
                           [](const Inputs& in) {
                             return ag::square(ag::sum(in[0]).reshape({1, 1}));
                           },
                           {x});
}

TEST(MethodGradients, Slice) {
  const Tensor x = randn64({5, 3}, 4);
  expect_grad_and_gradgrad("slice rows",
                           [](const Inputs& in) { return ag::slice(in[0], 0, 1, 4) * ag::slice(in[0], 0, 0, 3); }, {x});
  expect_grad_and_gradgrad("slice columns", [](const Inputs& in) { return ag::square(ag::slice(in[0], -1, 1, 3)); },
                           {x});
}

// to() crosses to float32 and back: the finite differences need a step that float32 rounding (6e-8 relative)
// does not swamp, and a tolerance above it. The function is quadratic, so the larger step costs no accuracy.
TEST(MethodGradients, ToFloat32AndBack) {
  const Tensor x = randn64({3, 2}, 5);
  const auto f = ag::SingleFunction([](const Inputs& in) { return in[0].to(kF32).to(kF64) * in[0]; });
  const ag::GradcheckOptions loose{.eps = 1e-3, .atol = 1e-4, .rtol = 1e-3};
  const auto first = ag::gradcheck("to(float32).to(float64)", f, {x}, loose);
  EXPECT_TRUE(first.ok) << first.message;
  const auto second = ag::gradgradcheck("to(float32).to(float64)", f, {x}, loose);
  EXPECT_TRUE(second.ok) << second.message;
  // The conversion itself is exact to float64 and back: a float64 round trip keeps the full gradient.
  expect_grad_and_gradgrad("to(float64) (no-op)", [](const Inputs& in) { return in[0].to(kF64) * ag::exp(in[0]); },
                           {x});
}

TEST(MethodGradients, MlpWithAnActivationOnItsLastLayer) {
  const Tensor x = randn64({4, 3}, 6), w0 = randn64({5, 3}, 7), w1 = randn64({2, 5}, 8), b0 = randn64({5}, 9),
               b1 = randn64({2}, 10);
  expect_grad_and_gradgrad("mlp, tanh on the last layer",
                           [](const Inputs& in) {
                             return ag::mlp(in[0], {in[1], in[2]}, {in[3], in[4]}, Fused::Tanh, Fused::Tanh);
                           },
                           {x, w0, w1, b0, b1});
  expect_grad_and_gradgrad("mlp without biases, tanh on the last layer",
                           [](const Inputs& in) {
                             return ag::mlp(in[0], {in[1], in[2]}, {}, Fused::Tanh, Fused::Tanh);
                           },
                           {x, w0, w1});
}

}  // namespace
