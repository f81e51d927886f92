// maps::diffusion::MlpDenoiser (issue 46): its layers applied by hand, gradients in the inputs and every parameter
// (gradcheck, float64), and refusals by name.

#include "maps/diffusion/mlp_denoiser.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "tests/common/error_of.h"
#include "tests/common/max_abs_diff.h"
#include "tests/maps/diffusion/diffusion_test_util.h"

namespace {

namespace ag = maps::ag;
using diffusiontest::randn64;
using maps::diffusion::MlpDenoiser;
using maps::diffusion::MlpDenoiserConfig;
using ::testing::HasSubstr;

MlpDenoiserConfig small() {
  MlpDenoiserConfig config;
  config.horizon = 4;
  config.action_dim = 2;
  config.cond_dim = 3;
  config.step_embed_dim = 8;
  config.hidden = {6, 5};
  return config;
}

TEST(MlpDenoiser, IsItsLayersByHand) {
  ag::Generator gen(1);
  MlpDenoiser net(small(), gen);
  net.to(ag::Dtype::Float64);
  const ag::Tensor noisy = randn64({2, 4, 2}, 2), cond = randn64({2, 3}, 3);
  const std::vector<int> steps{5, 80};
  auto& embed = static_cast<maps::diffusion::StepEmbedding&>(*net.named_children()[0].module);
  ag::Tensor x = ag::concat({ag::reshape(noisy, {2, 8}), embed.forward(steps), cond}, 1);
  const auto p = [&](const std::string& n) { return net.parameter(n); };
  x = ag::mish(ag::linear(x, p("layer0.weight"), p("layer0.bias")));
  x = ag::mish(ag::linear(x, p("layer1.weight"), p("layer1.bias")));
  x = ag::linear(x, p("layer2.weight"), p("layer2.bias"));
  EXPECT_LT(max_abs_diff(net.forward(noisy, steps, cond), ag::reshape(x, {2, 4, 2})), 1e-12);
}

TEST(MlpDenoiser, Gradcheck) {
  ag::Generator gen(4);
  MlpDenoiser net(small(), gen);
  net.to(ag::Dtype::Float64);
  std::vector<ag::Tensor> inputs = {randn64({2, 4, 2}, 5).requires_grad_(), randn64({2, 3}, 6).requires_grad_()};
  for (const auto& t : net.parameters()) inputs.push_back(t);
  const auto r = ag::gradcheck(
      "MlpDenoiser",
      [&](const std::vector<ag::Tensor>& in) {
        return net.forward(in[0], {1, 99}, in[1]);
      },
      inputs);
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(MlpDenoiser, RefusesOtherShapesByName) {
  ag::Generator gen(7);
  MlpDenoiser net(small(), gen);
  EXPECT_THAT(error_of([&] {
                net.forward(ag::zeros({2, 5, 2}), {0, 0}, ag::zeros({2, 3}));
              }),
              HasSubstr("expected noisy [batch, 4, 2], one step per row and cond [batch, 3], got [2, 5, 2]"));
  EXPECT_THAT(error_of([&] { net.forward(ag::zeros({2, 4, 2}), {0}, ag::zeros({2, 3})); }), HasSubstr("1 steps"));
  MlpDenoiserConfig none = small();
  none.hidden.clear();
  EXPECT_THAT(error_of([&] { MlpDenoiser(none, gen); }), HasSubstr("hidden not empty"));
}

}  // namespace
