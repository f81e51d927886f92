// maps::diffusion::NoiseSchedule (issue 46): the cosine schedule against its formula, the forward process, DDIM's
// timesteps, and the samplers' defining properties: DDIM (eta = 0) given the true noise walks the forward process's
// own path back to x0 exactly; clipping bounds the clean estimate; the DDPM step's mean and variance are the
// posterior's; refusals name the timestep.

#include "maps/diffusion/noise_schedule.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "tests/common/error_of.h"
#include "tests/maps/diffusion/diffusion_test_util.h"

namespace {

namespace ag = maps::ag;
using diffusiontest::randn64;
using maps::diffusion::NoiseSchedule;
using ::testing::HasSubstr;

constexpr double kPi = 3.14159265358979323846;

double abar_formula(double u, double steps) { return std::pow(std::cos((u / steps + 0.008) / 1.008 * kPi / 2), 2); }

double max_abs(const ag::Tensor& a, const ag::Tensor& b) {
  const auto x = a.to_vector(), y = b.to_vector();
  double worst = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) worst = std::max(worst, std::abs(x[i] - y[i]));
  return worst;
}

TEST(NoiseSchedule, CosineScheduleAsItsFormula) {
  const NoiseSchedule schedule(100);
  EXPECT_EQ(schedule.training_steps(), 100);
  for (int t = 0; t < 100; ++t) {
    const double beta = std::min(1.0 - abar_formula(t + 1, 100) / abar_formula(t, 100), 0.999);
    EXPECT_NEAR(schedule.beta(t), beta, 1e-15) << t;
    if (t > 0) {
      EXPECT_LT(schedule.alpha_bar(t), schedule.alpha_bar(t - 1));
    }
  }
  // Nearly clean at the first step, nearly pure noise at the last (the cap 0.999 binds there).
  EXPECT_GT(schedule.alpha_bar(0), 0.999);
  EXPECT_LT(schedule.alpha_bar(99), 1e-4);
  EXPECT_NEAR(schedule.beta(99), 0.999, 1e-12);
}

TEST(NoiseSchedule, AddNoiseScalesEachRowAtItsTimestep) {
  const NoiseSchedule schedule(100);
  const ag::Tensor x0 = randn64({3, 4}, 1), noise = randn64({3, 4}, 2);
  const ag::Tensor x = schedule.add_noise(x0, noise, {0, 50, 99});
  const auto xv = x.to_vector(), x0v = x0.to_vector(), nv = noise.to_vector();
  const int steps[] = {0, 50, 99};
  for (int row = 0; row < 3; ++row)
    for (int j = 0; j < 4; ++j) {
      const double abar = schedule.alpha_bar(steps[row]);
      EXPECT_NEAR(xv[row * 4 + j], std::sqrt(abar) * x0v[row * 4 + j] + std::sqrt(1 - abar) * nv[row * 4 + j], 1e-14);
    }
  EXPECT_THAT(error_of([&] { schedule.add_noise(x0, noise, {0, 1}); }), HasSubstr("one row per timestep (2)"));
  EXPECT_THAT(error_of([&] {
                schedule.add_noise(x0, noise, {0, 1, 100});
              }),
              HasSubstr("timestep 100 is not in [0, 99]"));
}

TEST(NoiseSchedule, DdimTimestepsLeadingSpacing) {
  const NoiseSchedule schedule(100);
  EXPECT_EQ(schedule.ddim_timesteps(8), (std::vector<int>{84, 72, 60, 48, 36, 24, 12, 0}));
  EXPECT_EQ(schedule.ddim_timesteps(1), (std::vector<int>{0}));
  EXPECT_EQ(schedule.ddim_timesteps(100).front(), 99);
  EXPECT_THAT(error_of([&] { schedule.ddim_timesteps(0); }), HasSubstr("inference steps must be in [1, 100]"));
}

// With the true noise as the estimate, each DDIM step lands on sqrt(abar_prev) x0 + sqrt(1 - abar_prev) noise, and
// the last one (previous = -1) on x0 itself.
TEST(NoiseSchedule, DdimWithTheTrueNoiseRetracesTheForwardProcess) {
  const NoiseSchedule schedule(100);
  const ag::Tensor x0 = ag::clamp(randn64({2, 6}, 3), -1.0, 1.0), noise = randn64({2, 6}, 4);
  const auto steps = schedule.ddim_timesteps(8);
  ag::Tensor x = schedule.add_noise(x0, noise, {steps[0], steps[0]});
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const int previous = i + 1 < steps.size() ? steps[i + 1] : -1;
    x = schedule.ddim_step(x, noise, steps[i], previous, /*clip=*/true);
    const ag::Tensor expected = previous < 0 ? x0 : schedule.add_noise(x0, noise, {previous, previous});
    EXPECT_LT(max_abs(x, expected), 1e-10) << "after step " << steps[i];
  }
}

TEST(NoiseSchedule, ClippingBoundsTheCleanEstimate) {
  const NoiseSchedule schedule(100);
  // Far from any clean sample in [-1, 1]: the final DDIM step returns the clipped estimate.
  const ag::Tensor x = ag::full({1, 3}, 5.0, ag::Dtype::Float64), zero = ag::zeros({1, 3}, ag::Dtype::Float64);
  for (double v : schedule.ddim_step(x, zero, 10, -1, true).to_vector()) EXPECT_NEAR(v, 1.0, 1e-12);
  for (double v : schedule.ddim_step(x, zero, 10, -1, false).to_vector())
    EXPECT_NEAR(v, 5.0 / std::sqrt(schedule.alpha_bar(10)), 1e-9);
}

TEST(NoiseSchedule, DdpmStepIsThePosterior) {
  const NoiseSchedule schedule(100);
  const ag::Tensor x0 = ag::clamp(randn64({2, 5}, 5), -1.0, 1.0), noise = randn64({2, 5}, 6), z = randn64({2, 5}, 7);
  const int t = 40;
  const ag::Tensor x_t = schedule.add_noise(x0, noise, {t, t});
  const double abar = schedule.alpha_bar(t), abar_prev = schedule.alpha_bar(t - 1), beta = schedule.beta(t);
  const double c0 = std::sqrt(abar_prev) * beta / (1 - abar), ct = std::sqrt(1 - beta) * (1 - abar_prev) / (1 - abar);
  const double sigma = std::sqrt((1 - abar_prev) / (1 - abar) * beta);
  const ag::Tensor expected = x0 * c0 + x_t * ct + z * sigma;
  EXPECT_LT(max_abs(schedule.ddpm_step(x_t, noise, t, z, true), expected), 1e-12);
  // At t = 0 no noise is added: the step returns the mean, which with the true noise is x0 (abar_prev = 1).
  const ag::Tensor x_0 = schedule.add_noise(x0, noise, {0, 0});
  EXPECT_LT(max_abs(schedule.ddpm_step(x_0, noise, 0, z, true), x0), 1e-12);
  EXPECT_THAT(error_of([&] { schedule.ddim_step(x_t, noise, 40, 40, true); }),
              HasSubstr("the previous timestep 40 must be in [-1, 39]"));
  EXPECT_THAT(error_of([] { NoiseSchedule(0); }), HasSubstr("training steps must be in [1, 100000]"));
}

}  // namespace
