// maps::diffusion::ConditionalUnet1d (issue 46): the shapes through the levels for a few horizons, Diffusion Policy's
// block layout (two residual blocks per level, a downsampling after every level but the last, the skips of all but
// the first level), gradients in the inputs' noise and condition and every parameter (gradcheck, float64, a tiny
// net), and refusals that name the horizon's constraint.

#include "maps/diffusion/unet1d.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>

#include "tests/common/error_of.h"
#include "tests/maps/diffusion/diffusion_test_util.h"

namespace {

namespace ag = maps::ag;
using diffusiontest::randn64;
using maps::diffusion::ConditionalUnet1d;
using maps::diffusion::Unet1dConfig;
using ::testing::HasSubstr;

Unet1dConfig small(std::vector<std::int64_t> dims) {
  Unet1dConfig config;
  config.action_dim = 3;
  config.cond_dim = 5;
  config.step_embed_dim = 8;
  config.down_dims = std::move(dims);
  config.kernel = 3;
  config.groups = 2;
  return config;
}

TEST(ConditionalUnet1d, ShapesAndLayout) {
  ag::Generator gen(1);
  ConditionalUnet1d net(small({4, 8, 16}), gen);
  std::vector<std::string> modules;
  for (const auto& child : net.named_children()) modules.push_back(child.name);
  EXPECT_EQ(modules,
            (std::vector<std::string>{"step_embedding", "down0_first", "down0_second", "down0_downsample",
                                      "down1_first", "down1_second", "down1_downsample", "down2_first", "down2_second",
                                      "mid_first", "mid_second", "up0_first", "up0_second", "up0_upsample", "up1_first",
                                      "up1_second", "up1_upsample", "final_block", "final_conv"}));
  // The first up level reads the last level's output beside its own skip: 2 x 16 channels in, 8 out.
  EXPECT_EQ(net.parameter("up0_first.first.conv.weight").shape(), (ag::Shape{8, 32, 3}));
  EXPECT_EQ(net.parameter("up1_first.first.conv.weight").shape(), (ag::Shape{4, 16, 3}));
  for (std::int64_t horizon : {4, 8, 16}) {
    ag::Generator data(horizon);
    const ag::Tensor noisy = ag::randn({2, horizon, 3}, data), cond = ag::randn({2, 5}, data);
    EXPECT_EQ(net.forward(noisy, {0, 50}, cond).shape(), (ag::Shape{2, horizon, 3}));
  }
}

TEST(ConditionalUnet1d, Gradcheck) {
  // About 1.4 s in Release; the sanitizer pass keeps its budget for the blocks' own gradcheck.
  if (std::getenv("MAPS_TEST_QUICK")) GTEST_SKIP() << "the whole net's gradcheck, run in the Release pass";
  ag::Generator gen(2);
  ConditionalUnet1d net(small({2, 4}), gen);
  net.to(ag::Dtype::Float64);
  std::vector<ag::Tensor> inputs = {randn64({2, 4, 3}, 3).requires_grad_(), randn64({2, 5}, 4).requires_grad_()};
  for (const auto& p : net.parameters()) inputs.push_back(p);
  const auto r = ag::gradcheck(
      "ConditionalUnet1d",
      [&](const std::vector<ag::Tensor>& in) {
        return net.forward(in[0], {3, 60}, in[1]);
      },
      inputs);
  EXPECT_TRUE(r.ok) << r.message;
}

TEST(ConditionalUnet1d, RefusesWhatCannotBeMeant) {
  ag::Generator gen(5);
  ConditionalUnet1d net(small({4, 8, 16}), gen);
  EXPECT_THAT(error_of([&] {
                net.forward(ag::zeros({2, 6, 3}), {0, 0}, ag::zeros({2, 5}));
              }),
              HasSubstr("horizon divisible by 4"));
  EXPECT_THAT(error_of([&] { net.forward(ag::zeros({2, 8, 3}), {0}, ag::zeros({2, 5})); }), HasSubstr("1 steps"));
  EXPECT_THAT(error_of([&] {
                net.forward(ag::zeros({2, 8, 3}), {0, 1}, ag::zeros({2, 4}));
              }),
              HasSubstr("cond [batch, 5]"));
}

}  // namespace
