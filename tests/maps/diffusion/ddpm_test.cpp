// Training and sampling (maps/diffusion/ddpm.h, issue 46): the loss is the noise-prediction error at the drawn steps
// (checked against the schedule and the denoiser applied by hand), sampling runs without a graph, and a tiny U-Net
// trained by the loss on two conditions, each with its own action chunk, samples each condition's chunk by DDIM.

#include "maps/diffusion/ddpm.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "maps/diffusion/unet1d.h"
#include "nn/optim/adam.h"
#include "tests/common/error_of.h"

namespace {

namespace ag = maps::ag;
using maps::diffusion::ConditionalUnet1d;
using maps::diffusion::NoiseSchedule;
using maps::diffusion::Unet1dConfig;
using ::testing::HasSubstr;

Unet1dConfig tiny() {
  Unet1dConfig config;
  config.action_dim = 2;
  config.cond_dim = 2;
  config.step_embed_dim = 16;
  config.down_dims = {16, 32};
  config.kernel = 3;
  config.groups = 4;
  return config;
}

TEST(Ddpm, LossIsTheNoiseEstimatesError) {
  ag::Generator gen(1), draws(2), replay(2);
  ConditionalUnet1d net(tiny(), gen);
  const NoiseSchedule schedule(100);
  const ag::Tensor chunks = ag::full({3, 4, 2}, 0.5), cond = ag::full({3, 2}, 1.0);
  const ag::Tensor loss = maps::diffusion::denoising_loss(net, schedule, chunks, cond, draws);
  // The same draws by hand: the steps first, then the noise.
  std::vector<int> steps(3);
  for (int& t : steps) t = static_cast<int>(replay.next_u64() % 100);
  const ag::Tensor noise = ag::randn({3, 4, 2}, replay);
  const ag::Tensor expected = ag::mse_loss(net.forward(schedule.add_noise(chunks, noise, steps), steps, cond), noise);
  EXPECT_NEAR(loss.item(), expected.item(), 1e-6);
  EXPECT_TRUE(loss.requires_grad());
  EXPECT_THAT(error_of([&] {
                maps::diffusion::denoising_loss(net, schedule, chunks, ag::full({2, 2}, 1.0), draws);
              }),
              HasSubstr("expected chunks [batch, horizon, actions] and cond [batch, C], got [3, 4, 2] and [2, 2]"));
}

TEST(Ddpm, LearnsOneChunkPerConditionAndSamplesIt) {
  if (std::getenv("MAPS_TEST_QUICK")) GTEST_SKIP() << "a learning check, run in the Release pass";
  ag::Generator gen(3), draws(4);
  ConditionalUnet1d net(tiny(), gen);
  const NoiseSchedule schedule(100);
  // Condition [1, 0]: every action 0.5; condition [0, 1]: a ramp over the chunk, the second action its negative.
  std::vector<double> chunk_values, cond_values;
  for (int row = 0; row < 32; ++row) {
    const bool ramp = row % 2 == 1;
    for (int h = 0; h < 4; ++h) {
      const double r = -0.6 + 0.4 * h;
      chunk_values.push_back(ramp ? r : 0.5);
      chunk_values.push_back(ramp ? -r : 0.5);
    }
    cond_values.push_back(ramp ? 0.0 : 1.0);
    cond_values.push_back(ramp ? 1.0 : 0.0);
  }
  const ag::Tensor chunks = ag::from_vector(chunk_values, {32, 4, 2}), cond = ag::from_vector(cond_values, {32, 2});
  maps::optim::Adam adam(net.parameters(), {.lr = 2e-3});
  double first = 0.0, last = 0.0;
  for (int step = 0; step < 1500; ++step) {
    adam.zero_grad();
    const ag::Tensor loss = maps::diffusion::denoising_loss(net, schedule, chunks, cond, draws);
    loss.backward();
    adam.step();
    if (step < 50) first += loss.item() / 50;
    if (step >= 1450) last += loss.item() / 50;
  }
  EXPECT_LT(last, 0.3 * first) << "first " << first << ", last " << last;
  const ag::Tensor samples =
      maps::diffusion::sample_ddim(net, schedule, ag::narrow(cond, 0, 0, 8), 4, 2, 10, /*clip=*/true, draws);
  EXPECT_FALSE(samples.requires_grad());
  // Each sample is its own condition's chunk: within 0.25 everywhere and 0.06 on average, where the two chunks are
  // 0.1-1.1 apart.
  const auto got = samples.to_vector();
  double worst = 0.0, total = 0.0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    worst = std::max(worst, std::abs(got[i] - chunk_values[i]));
    total += std::abs(got[i] - chunk_values[i]) / static_cast<double>(got.size());
  }
  EXPECT_LT(worst, 0.25) << "mean error " << total;
  EXPECT_LT(total, 0.06) << "worst error " << worst;
}

}  // namespace
