// nn/functional.h (issue 46): layer and group normalisation, the 1-D convolution, down- and upsampling by 2 and the
// sinusoidal step embedding, each against a hand computation or a direct loop, with gradcheck and gradgradcheck in
// float64 for every differentiable one, and the refusals of shapes that cannot be meant.

#include "nn/functional.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "autograd/autograd.h"
#include "tests/nn/nn_test_util.h"

namespace {

namespace ag = maps::ag;
namespace F = maps::nn::functional;
using ag::Dtype;
using ag::Shape;
using ag::Tensor;
using nntest::HasSubstr;

Tensor randn64(const Shape& shape, std::uint64_t seed) {
  ag::Generator gen(seed);
  return ag::randn(shape, gen, Dtype::Float64).requires_grad_();
}

void expect_gradients(const char* name, const ag::SingleFunction& f, const std::vector<Tensor>& inputs) {
  const auto first = ag::gradcheck(name, f, inputs);
  EXPECT_TRUE(first.ok) << first.message;
  const auto second = ag::gradgradcheck(name, f, inputs);
  EXPECT_TRUE(second.ok) << second.message;
}

void expect_near_all(const Tensor& actual, const std::vector<double>& expected, double tolerance) {
  const auto values = actual.to_vector();
  ASSERT_EQ(values.size(), expected.size());
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_NEAR(values[i], expected[i], tolerance) << "element " << i;
}

TEST(Functional, LayerNormHasZeroMeanAndUnitVariancePerRow) {
  const Tensor x = ag::from_vector({1, 2, 3, 4, -2, 0, 2, 8}, {2, 4}, Dtype::Float64);
  const Tensor y = F::layer_norm(x, 1, 1e-12);
  // Row 1: mean 2.5, biased variance 1.25.
  const double s = std::sqrt(1.25);
  expect_near_all(ag::narrow(y, 0, 0, 1), {-1.5 / s, -0.5 / s, 0.5 / s, 1.5 / s}, 1e-9);
  for (std::int64_t row = 0; row < 2; ++row) {
    const auto v = ag::narrow(y, 0, row, 1).to_vector();
    double mean = 0, square = 0;
    for (double e : v) mean += e / 4, square += e * e / 4;
    EXPECT_NEAR(mean, 0.0, 1e-12);
    EXPECT_NEAR(square, 1.0, 1e-9);
  }
  // Over the last two dims: the whole [2, 4] as one group.
  const auto whole = F::layer_norm(ag::reshape(x, {1, 2, 4}), 2, 1e-12).to_vector();
  double mean = 0;
  for (double e : whole) mean += e / 8;
  EXPECT_NEAR(mean, 0.0, 1e-12);
}

TEST(Functional, LayerNormGradients) {
  expect_gradients("layer_norm", [](const std::vector<Tensor>& in) { return F::layer_norm(in[0]); },
                   {randn64({3, 5}, 1)});
  expect_gradients("layer_norm(2 dims)", [](const std::vector<Tensor>& in) { return F::layer_norm(in[0], 2); },
                   {randn64({2, 3, 4}, 2)});
}

TEST(Functional, GroupNormIsLayerNormOverEachGroupOfChannels) {
  const Tensor x = randn64({2, 6, 5}, 3).detach();
  const Tensor y = F::group_norm(x, 3);
  // Group 1 of batch row 1: channels 2-3, all positions.
  const Tensor group = ag::reshape(ag::narrow(ag::narrow(x, 0, 1, 1), 1, 2, 2), {1, 10});
  const Tensor expected = F::layer_norm(group);
  const Tensor actual = ag::reshape(ag::narrow(ag::narrow(y, 0, 1, 1), 1, 2, 2), {1, 10});
  expect_near_all(actual, expected.to_vector(), 1e-12);
  expect_gradients("group_norm", [](const std::vector<Tensor>& in) { return F::group_norm(in[0], 2); },
                   {randn64({2, 4, 3}, 4)});
  EXPECT_THAT(nntest::error_of([&] { F::group_norm(x, 4); }), HasSubstr("6 channels do not split into 4 groups"));
}

// The functional form is the autograd op (tests/autograd/conv_ops_test.cpp checks it against its definition, its
// gradients and its refusals).
TEST(Functional, Conv1dIsTheAutogradOp) {
  const Tensor x = randn64({2, 3, 7}, 5), w = randn64({4, 3, 5}, 6), b = randn64({4}, 7);
  const Tensor y = F::conv1d(x, w, b, 2);
  expect_near_all(y, ag::conv1d(x, w, b, 2).to_vector(), 0.0);
  ASSERT_TRUE(y.requires_grad());
  EXPECT_THAT(nntest::error_of([&] {
                F::conv1d(x, ag::zeros({4, 2, 3}, Dtype::Float64), Tensor(), 1);
              }),
              HasSubstr("expected weight of shape [out, 3, kernel]"));
}

TEST(Functional, DownsampleAndUpsampleByTwo) {
  const Tensor x = ag::from_vector({0, 1, 2, 3, 10, 11, 12, 13}, {1, 2, 4}, Dtype::Float64);
  expect_near_all(F::downsample2(x), {0, 2, 10, 12}, 0.0);
  expect_near_all(F::upsample2(x), {0, 0, 1, 1, 2, 2, 3, 3, 10, 10, 11, 11, 12, 12, 13, 13}, 0.0);
  expect_gradients("downsample2", [](const std::vector<Tensor>& in) { return F::downsample2(in[0]); },
                   {randn64({2, 3, 4}, 13)});
  expect_gradients("upsample2", [](const std::vector<Tensor>& in) { return F::upsample2(in[0]); },
                   {randn64({2, 3, 4}, 14)});
  EXPECT_THAT(nntest::error_of([&] { F::downsample2(ag::zeros({1, 2, 5})); }), HasSubstr("the length must be even"));
  EXPECT_THAT(nntest::error_of([&] {
                F::upsample2(ag::zeros({2, 4}));
              }),
              HasSubstr("upsample2: expected x of shape [batch, channels, length], got [2, 4]"));
  EXPECT_THAT(nntest::error_of([&] { F::downsample2(Tensor()); }),
              HasSubstr("downsample2: the x is an undefined tensor"));
}

TEST(Functional, SinusoidalEmbeddingByHand) {
  // dim 4: frequencies 1 and 10000^-1.
  const Tensor e = F::sinusoidal_embedding({0.0, 2.0}, 4, Dtype::Float64);
  EXPECT_EQ(e.shape(), (Shape{2, 4}));
  EXPECT_FALSE(e.requires_grad());
  expect_near_all(e, {0, 0, 1, 1, std::sin(2.0), std::sin(2e-4), std::cos(2.0), std::cos(2e-4)}, 1e-15);
  EXPECT_THAT(nntest::error_of([] { F::sinusoidal_embedding({1.0}, 6 + 1); }), HasSubstr("dim must be even"));
  EXPECT_THAT(nntest::error_of([] { F::sinusoidal_embedding({1.0}, 2); }), HasSubstr("at least 4"));
  EXPECT_THAT(nntest::error_of([] { F::sinusoidal_embedding({std::nan("")}, 4); }), HasSubstr("not finite"));
}

}  // namespace
