// nn::Conv1d, nn::LayerNorm and nn::GroupNorm (issue 46): the modules are their functions with their own parameters,
// named as PyTorch names them, initialised as PyTorch does, differentiable in input and parameters (gradcheck,
// float64), and they refuse inputs of another shape by name.

#include <cmath>

#include "nn_test_util.h"

namespace nntest {
namespace {

namespace F = maps::nn::functional;

Tensor randn64(const Shape& shape, std::uint64_t seed) {
  ag::Generator gen(seed);
  return ag::randn(shape, gen, Dtype::Float64);
}

template <typename M>
void expect_module_gradients(const char* name, M& module, const Tensor& x) {
  module.to(Dtype::Float64);
  std::vector<Tensor> inputs = {x.detach().requires_grad_()};
  for (const auto& p : module.parameters()) inputs.push_back(p);
  const auto r = ag::gradcheck(
      name, [&](const std::vector<Tensor>& in) { return module.forward(in[0]); }, inputs);
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(Conv1d, IsTheFunctionWithItsParametersInitialisedAsPyTorch) {
  ag::Generator gen(1);
  nn::Conv1d conv(3, 4, 5, 2, gen);
  const auto named = conv.named_parameters();
  ASSERT_EQ(named.size(), 2u);
  EXPECT_EQ(named[0].name, "weight");
  EXPECT_EQ(named[0].tensor.shape(), (Shape{4, 3, 5}));
  EXPECT_EQ(named[1].name, "bias");
  const double bound = 1.0 / std::sqrt(15.0);
  for (const auto& [name, p] : named)
    for (double v : p.to_vector()) {
      EXPECT_LE(std::abs(v), bound) << name;
    }
  const Tensor x = randn64({2, 3, 8}, 2).to(Dtype::Float32);
  const Tensor y = conv.forward(x);
  EXPECT_EQ(y.shape(), (Shape{2, 4, 8}));
  EXPECT_LT(max_abs_diff(y, F::conv1d(x, named[0].tensor, named[1].tensor, 2)), 1e-6);
  expect_module_gradients("Conv1d", conv, randn64({2, 3, 6}, 3));
  nn::Conv1d plain(2, 2, 1, 0, gen, /*bias=*/false);
  EXPECT_EQ(plain.named_parameters().size(), 1u);
  EXPECT_THAT(error_of([&] { nn::Conv1d(2, 2, 0, 0, gen); }), HasSubstr("channels and kernel must be positive"));
}

TEST(LayerNorm, AffineAfterTheNormalisation) {
  nn::LayerNorm norm(4);
  const auto named = norm.named_parameters();
  ASSERT_EQ(named.size(), 2u);
  EXPECT_EQ(named[0].name, "weight");
  EXPECT_EQ(named[1].name, "bias");
  const Tensor x = randn64({3, 4}, 4).to(Dtype::Float32);
  EXPECT_LT(max_abs_diff(norm.forward(x), F::layer_norm(x)), 1e-6);
  expect_module_gradients("LayerNorm", norm, randn64({3, 4}, 5));
  EXPECT_THAT(error_of([&] { norm.forward(randn64({3, 5}, 6)); }), HasSubstr("expected input [..., 4], got [3, 5]"));
}

TEST(GroupNorm, PerChannelAffineAfterTheGroups) {
  nn::GroupNorm norm(2, 4);
  const auto named = norm.named_parameters();
  ASSERT_EQ(named.size(), 2u);
  EXPECT_EQ(named[0].tensor.shape(), (Shape{4}));
  norm.to(Dtype::Float64);
  // Channel c scaled by c + 1 and shifted by -c.
  ag::Tensor weight = norm.named_parameters()[0].tensor;
  ag::Tensor bias = norm.named_parameters()[1].tensor;
  {
    ag::NoGradGuard guard;
    weight.copy_(tensor({1, 2, 3, 4}, {4}));
    bias.copy_(tensor({0, -1, -2, -3}, {4}));
  }
  const Tensor x = randn64({2, 4, 3}, 7);
  const auto normalised = F::group_norm(x, 2).to_vector();
  const auto y = norm.forward(x).to_vector();
  for (std::size_t i = 0; i < y.size(); ++i) {
    const double c = static_cast<double>((i / 3) % 4);
    EXPECT_NEAR(y[i], normalised[i] * (c + 1) - c, 1e-12) << i;
  }
  expect_module_gradients("GroupNorm", norm, randn64({2, 4, 3}, 8));
  EXPECT_THAT(error_of([&] { nn::GroupNorm(3, 4); }), HasSubstr("4 channels do not split into 3 groups"));
  EXPECT_THAT(error_of([&] { norm.forward(randn64({2, 4}, 9)); }), HasSubstr("expected input [batch, 4, length]"));
}

}  // namespace
}  // namespace nntest
