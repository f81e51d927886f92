// Diffusion Policy's U-Net blocks (maps/diffusion/conditional_blocks.h, issue 46): each is its composition of nn's
// layers (checked against the same layers applied by hand), differentiable in its inputs and every parameter
// (gradcheck, float64), with PyTorch-style dotted parameter names, and refusing inputs of another shape by name.

#include "maps/diffusion/conditional_blocks.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/common/error_of.h"
#include "tests/common/max_abs_diff.h"
#include "tests/maps/diffusion/diffusion_test_util.h"

namespace {

namespace ag = maps::ag;
namespace nn = maps::nn;
namespace F = maps::nn::functional;
using diffusiontest::randn64;
using maps::diffusion::ConditionalResidualBlock1d;
using maps::diffusion::StepEmbedding;
using ::testing::HasSubstr;

std::vector<std::string> names(const nn::Module& m) {
  std::vector<std::string> out;
  for (const auto& p : m.named_parameters()) out.push_back(p.name);
  return out;
}

TEST(StepEmbedding, SinusoidThroughTwoLayersWithMish) {
  ag::Generator gen(1);
  StepEmbedding embed(8, gen);
  embed.to(ag::Dtype::Float64);
  EXPECT_EQ(names(embed), (std::vector<std::string>{"first.weight", "first.bias", "second.weight", "second.bias"}));
  const ag::Tensor e = embed.forward({0, 7, 99});
  EXPECT_EQ(e.shape(), (ag::Shape{3, 8}));
  const ag::Tensor s = F::sinusoidal_embedding({0, 7, 99}, 8, ag::Dtype::Float64);
  const ag::Tensor hidden = ag::mish(ag::linear(s, embed.parameter("first.weight"), embed.parameter("first.bias")));
  EXPECT_LT(max_abs_diff(e, ag::linear(hidden, embed.parameter("second.weight"), embed.parameter("second.bias"))),
            1e-12);
  EXPECT_THAT(error_of([&] { StepEmbedding(6 - 1, gen); }), HasSubstr("dim must be even"));
}

TEST(ConditionalResidualBlock1d, IsItsLayersComposed) {
  ag::Generator gen(2);
  ConditionalResidualBlock1d block(3, 4, 5, 3, 2, gen);
  block.to(ag::Dtype::Float64);
  EXPECT_EQ(names(block), (std::vector<std::string>{"first.conv.weight", "first.conv.bias", "first.norm.weight",
                                                    "first.norm.bias", "second.conv.weight", "second.conv.bias",
                                                    "second.norm.weight", "second.norm.bias", "film.weight",
                                                    "film.bias", "residual.weight", "residual.bias"}));
  const ag::Tensor x = randn64({2, 3, 6}, 3), c = randn64({2, 5}, 4);
  const auto p = [&](const char* n) { return block.parameter(n); };
  auto conv_block = [&](const ag::Tensor& in, const std::string& which) {
    const ag::Tensor conv = F::conv1d(in, p((which + ".conv.weight").c_str()), p((which + ".conv.bias").c_str()), 1);
    const ag::Tensor norm = F::group_norm(conv, 2) * ag::reshape(p((which + ".norm.weight").c_str()), {4, 1}) +
                            ag::reshape(p((which + ".norm.bias").c_str()), {4, 1});
    return ag::mish(norm);
  };
  const ag::Tensor film = ag::linear(ag::mish(c), p("film.weight"), p("film.bias"));  // [2, 8]: scales then biases
  const ag::Tensor scale = ag::reshape(ag::narrow(film, 1, 0, 4), {2, 4, 1});
  const ag::Tensor bias = ag::reshape(ag::narrow(film, 1, 4, 4), {2, 4, 1});
  const ag::Tensor expected = conv_block(scale * conv_block(x, "first") + bias, "second") +
                              F::conv1d(x, p("residual.weight"), p("residual.bias"), 0);
  EXPECT_LT(max_abs_diff(block.forward(x, c), expected), 1e-12);
  // Same widths: the input itself is the shortcut, no 1 x 1 convolution.
  ConditionalResidualBlock1d same(4, 4, 5, 3, 2, gen);
  EXPECT_EQ(same.named_parameters().size(), 10u);
}

TEST(ConditionalResidualBlock1d, Gradcheck) {
  ag::Generator gen(5);
  ConditionalResidualBlock1d block(2, 4, 3, 3, 2, gen);
  block.to(ag::Dtype::Float64);
  std::vector<ag::Tensor> inputs = {randn64({2, 2, 4}, 6).requires_grad_(), randn64({2, 3}, 7).requires_grad_()};
  for (const auto& t : block.parameters()) inputs.push_back(t);
  const auto r = ag::gradcheck(
      "ConditionalResidualBlock1d", [&](const std::vector<ag::Tensor>& in) { return block.forward(in[0], in[1]); },
      inputs);
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(ConditionalResidualBlock1d, RefusesOtherShapesByName) {
  ag::Generator gen(8);
  ConditionalResidualBlock1d block(3, 4, 5, 3, 2, gen);
  EXPECT_THAT(error_of([&] {
                block.forward(ag::zeros({2, 4, 6}), ag::zeros({2, 5}));
              }),
              HasSubstr("expected x [batch, 3, length] and cond [batch, 5], got [2, 4, 6] and [2, 5]"));
  EXPECT_THAT(error_of([&] {
                block.forward(ag::zeros({2, 3, 6}), ag::zeros({3, 5}));
              }),
              HasSubstr("got [2, 3, 6] and [3, 5]"));
  EXPECT_THAT(error_of([&] { ConditionalResidualBlock1d(3, 4, 5, 4, 2, gen); }), HasSubstr("the kernel must be odd"));
  EXPECT_THAT(error_of([&] { ConditionalResidualBlock1d(3, 6, 5, 3, 4, gen); }),
              HasSubstr("6 channels do not split into 4 groups"));
}

}  // namespace
