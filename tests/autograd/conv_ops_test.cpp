// The 1-D convolution ops (ops_conv.cpp): conv1d against its definition, its two adjoints against the gradients
// they stand for, gradcheck and gradgradcheck in float64 for all three over kernels and paddings (padding past the
// kernel too), float32 against float64, threads against one, and the refusals.

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "autograd/autograd.h"
#include "tests/autograd/test_util.h"

namespace {

namespace ag = maps::ag;
using ag::Shape;
using ag::Tensor;
using agtest::expect_close;
using agtest::expect_grad_and_gradgrad;
using agtest::expect_throw_with;
using agtest::kF32;
using agtest::kF64;
using agtest::randn64;

using Inputs = std::vector<Tensor>;

// out[b, o, t] = bias[o] + sum_{c, k} w[o, c, k] x[b, c, t + k - padding], zero outside x.
std::vector<double> conv1d_by_definition(const Tensor& x, const Tensor& w, const Tensor& bias, std::int64_t padding) {
  const std::int64_t batch = x.size(0), in = x.size(1), length = x.size(2);
  const std::int64_t out = w.size(0), kernel = w.size(2), out_length = length + 2 * padding - kernel + 1;
  const auto xv = x.to_vector(), wv = w.to_vector();
  const auto bv = bias.defined() ? bias.to_vector() : std::vector<double>(static_cast<std::size_t>(out), 0.0);
  std::vector<double> result;
  for (std::int64_t b = 0; b < batch; ++b)
    for (std::int64_t o = 0; o < out; ++o)
      for (std::int64_t t = 0; t < out_length; ++t) {
        double sum = bv[o];
        for (std::int64_t c = 0; c < in; ++c)
          for (std::int64_t k = 0; k < kernel; ++k) {
            const std::int64_t at = t + k - padding;
            if (at >= 0 && at < length) sum += wv[(o * in + c) * kernel + k] * xv[(b * in + c) * length + at];
          }
        result.push_back(sum);
      }
  return result;
}

// (kernel, padding): U-Net's 5/2 and 3/1, a pointwise 1/0, an even kernel, and padding past the kernel.
const std::vector<std::pair<std::int64_t, std::int64_t>> kKernelPaddings{{1, 0}, {3, 1}, {5, 2}, {4, 0}, {2, 3}};

TEST(Conv1d, MatchesItsDefinition) {
  for (const auto& [kernel, padding] : kKernelPaddings) {
    SCOPED_TRACE("kernel " + std::to_string(kernel) + ", padding " + std::to_string(padding));
    const Tensor x = randn64({3, 4, 7}, 1, false), w = randn64({5, 4, kernel}, 2, false), b = randn64({5}, 3, false);
    for (const Tensor& bias : {b, Tensor()}) {
      const Tensor y = ag::conv1d(x, w, bias, padding);
      EXPECT_EQ(y.shape(), (Shape{3, 5, 7 + 2 * padding - kernel + 1}));
      agtest::expect_values(y, y.shape(), conv1d_by_definition(x, w, bias, padding), 1e-12);
    }
  }
}

// A kernel longer than x: no window lies inside x, every position reads padding (the ends' path alone).
TEST(Conv1d, AKernelLongerThanTheInputReadsPaddingEverywhere) {
  const Tensor x = randn64({2, 3, 3}, 17), w = randn64({2, 3, 5}, 18), b = randn64({2}, 19);
  const Tensor y = ag::conv1d(x.detach(), w.detach(), b.detach(), 2);
  EXPECT_EQ(y.shape(), (Shape{2, 2, 3}));
  agtest::expect_values(y, y.shape(), conv1d_by_definition(x, w, b, 2), 1e-12);
  expect_grad_and_gradgrad("conv1d (length 3, kernel 5)",
                           [](const Inputs& in) { return ag::conv1d(in[0], in[1], in[2], 2); }, {x, w, b});
}

TEST(Conv1d, AdjointsAreTheGradientsOfConv1d) {
  for (const auto& [kernel, padding] : kKernelPaddings) {
    SCOPED_TRACE("kernel " + std::to_string(kernel) + ", padding " + std::to_string(padding));
    const Tensor x = randn64({2, 3, 6}, 4), w = randn64({4, 3, kernel}, 5);
    const Tensor y = ag::conv1d(x, w, Tensor(), padding);
    const Tensor g = randn64(y.shape(), 6, false);
    const auto grads = ag::grad({ag::sum(y * g)}, {x, w});
    expect_close(ag::conv1d_input_grad(g, w.detach(), 6, padding), grads[0]);
    expect_close(ag::conv1d_weight_grad(x.detach(), g, kernel, padding), grads[1]);
  }
}

TEST(Conv1d, GradcheckAndGradgradcheck) {
  for (const auto& [kernel, padding] : kKernelPaddings) {
    const std::string shape = "(kernel " + std::to_string(kernel) + ", padding " + std::to_string(padding) + ")";
    const std::int64_t p = padding, k = kernel, out_length = 5 + 2 * padding - kernel + 1;
    expect_grad_and_gradgrad("conv1d " + shape, [p](const Inputs& in) { return ag::conv1d(in[0], in[1], in[2], p); },
                             {randn64({2, 3, 5}, 7), randn64({2, 3, kernel}, 8), randn64({2}, 9)});
    expect_grad_and_gradgrad("conv1d_input_grad " + shape,
                             [p](const Inputs& in) { return ag::conv1d_input_grad(in[0], in[1], 5, p); },
                             {randn64({2, 2, out_length}, 10), randn64({2, 3, kernel}, 11)});
    expect_grad_and_gradgrad("conv1d_weight_grad " + shape,
                             [p, k](const Inputs& in) { return ag::conv1d_weight_grad(in[0], in[1], k, p); },
                             {randn64({2, 3, 5}, 12), randn64({2, 2, out_length}, 13)});
  }
}

TEST(Conv1d, Float32AgreesWithFloat64AndTwoThreadsWithOne) {
  const Tensor x = randn64({16, 24, 16}, 14, false), w = randn64({48, 24, 5}, 15, false), b = randn64({48}, 16, false);
  const Tensor expected = ag::conv1d(x, w, b, 2);
  // The forward and both gradients (col2im, the weight's GEMM, the transposes) on `threads` threads, in float32.
  const auto run = [&](int threads) {
    const int before = ag::num_threads();
    ag::set_num_threads(threads);
    const Tensor x32 = x.to(kF32).requires_grad_(), w32 = w.to(kF32).requires_grad_();
    const Tensor y = ag::conv1d(x32, w32, b.to(kF32), 2);
    const auto grads = ag::grad({ag::sum(ag::square(y))}, {x32, w32});
    ag::set_num_threads(before);
    return std::vector<Tensor>{y.detach(), grads[0], grads[1]};
  };
  const std::vector<Tensor> one = run(1), two = run(2);
  EXPECT_EQ(one[0].dtype(), kF32);
  expect_close(one[0].to(kF64), expected, 1e-4);
  for (std::size_t i = 0; i < one.size(); ++i) expect_close(two[i], one[i], 0.0);
}

TEST(Conv1d, RefusesShapesThatCannotBeMeant) {
  const Tensor x = ag::zeros({2, 3, 4}, kF64);
  expect_throw_with(
      [&] {
        ag::conv1d(x, ag::zeros({4, 2, 3}, kF64), Tensor(), 1);
      },
      {"conv1d", "expected weight of shape [out, 3, kernel]"});
  expect_throw_with(
      [&] {
        ag::conv1d(ag::zeros({3, 4}, kF64), ag::zeros({4, 3, 3}, kF64), Tensor(), 1);
      },
      {"expected x of shape [batch, channels, length]"});
  expect_throw_with(
      [&] {
        ag::conv1d(x, ag::zeros({4, 3, 7}, kF64), Tensor(), 1);
      },
      {"longer than the padded length 6"});
  expect_throw_with([&] { ag::conv1d(x, ag::zeros({4, 3, 3}, kF64), Tensor(), -1); }, {"padding must be >= 0"});
  expect_throw_with(
      [&] {
        ag::conv1d(x, ag::zeros({4, 3, 3}, kF64), ag::zeros({3}, kF64), 1);
      },
      {"expected bias of shape [4]"});
  expect_throw_with(
      [&] {
        ag::conv1d(x, ag::zeros({4, 3, 3}, kF32), Tensor(), 1);
      },
      {"conv1d: dtypes differ: weight [4, 3, 3] float32 and x [2, 3, 4] float64"});
  expect_throw_with(
      [&] {
        ag::conv1d(x, ag::zeros({4, 3, 3}, kF64), ag::zeros({4}, kF32), 1);
      },
      {"conv1d: dtypes differ: bias [4] float32 and x [2, 3, 4] float64"});
  expect_throw_with(
      [&] {
        ag::conv1d_input_grad(ag::zeros({2, 4, 5}, kF64), ag::zeros({4, 3, 3}, kF64), 4, 1);
      },
      {"conv1d_input_grad", "is not the output of weight [4, 3, 3] on length 4"});
  expect_throw_with(
      [&] {
        ag::conv1d_weight_grad(x, ag::zeros({2, 4, 3}, kF64), 3, 1);
      },
      {"conv1d_weight_grad", "is not the output of a kernel of 3"});
  expect_throw_with(
      [&] {
        ag::conv1d_weight_grad(x, ag::zeros({1, 4, 4}, kF64), 3, 1);
      },
      {"conv1d_weight_grad: grad_output [1, 4, 4] has 1 rows, x [2, 3, 4] 2"});
}

}  // namespace
