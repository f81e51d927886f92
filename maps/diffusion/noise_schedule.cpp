#include "maps/diffusion/noise_schedule.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace maps::diffusion {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxBeta = 0.999;

// Row i of a [rows, ...] tensor scaled by factors[i].
ag::Tensor scale_rows(const ag::Tensor& x, const std::vector<double>& factors) {
  ag::Shape shape(static_cast<std::size_t>(x.dim()), 1);
  shape[0] = x.size(0);
  return x * ag::from_vector(factors, shape, x.dtype());
}

}  // namespace

NoiseSchedule::NoiseSchedule(int training_steps) {
  if (training_steps < 1 || training_steps > 100000)
    throw std::invalid_argument("NoiseSchedule: training steps must be in [1, 100000], got " +
                                std::to_string(training_steps));
  const double steps = training_steps;
  auto abar = [steps](double u) { return std::pow(std::cos((u / steps + 0.008) / 1.008 * kPi / 2), 2); };
  double product = 1.0;
  for (int t = 0; t < training_steps; ++t) {
    const double beta = std::min(1.0 - abar(t + 1) / abar(t), kMaxBeta);
    betas_.push_back(beta);
    product *= 1.0 - beta;
    alpha_bars_.push_back(product);
  }
}

void NoiseSchedule::check_timestep(int t, const char* what) const {
  if (t < 0 || t >= training_steps())
    throw std::invalid_argument(std::string(what) + ": timestep " + std::to_string(t) + " is not in [0, " +
                                std::to_string(training_steps() - 1) + "]");
}

double NoiseSchedule::beta(int t) const {
  check_timestep(t, "NoiseSchedule::beta");
  return betas_[static_cast<std::size_t>(t)];
}

double NoiseSchedule::alpha_bar(int t) const {
  check_timestep(t, "NoiseSchedule::alpha_bar");
  return alpha_bars_[static_cast<std::size_t>(t)];
}

ag::Tensor NoiseSchedule::add_noise(const ag::Tensor& x0, const ag::Tensor& noise,
                                    const std::vector<int>& timesteps) const {
  if (x0.shape() != noise.shape() || x0.dim() < 1 || static_cast<std::size_t>(x0.size(0)) != timesteps.size())
    throw std::invalid_argument("NoiseSchedule::add_noise: x0 " + ag::to_string(x0.shape()) + " and noise " +
                                ag::to_string(noise.shape()) + " must have the same shape, one row per timestep (" +
                                std::to_string(timesteps.size()) + ")");
  std::vector<double> signal, spread;
  for (int t : timesteps) {
    const double abar = alpha_bar(t);
    signal.push_back(std::sqrt(abar));
    spread.push_back(std::sqrt(1.0 - abar));
  }
  return scale_rows(x0, signal) + scale_rows(noise, spread);
}

std::vector<int> NoiseSchedule::ddim_timesteps(int inference_steps) const {
  if (inference_steps < 1 || inference_steps > training_steps())
    throw std::invalid_argument("NoiseSchedule::ddim_timesteps: inference steps must be in [1, " +
                                std::to_string(training_steps()) + "], got " + std::to_string(inference_steps));
  const int ratio = training_steps() / inference_steps;
  std::vector<int> steps;
  for (int i = inference_steps - 1; i >= 0; --i) steps.push_back(i * ratio);
  return steps;
}

ag::Tensor NoiseSchedule::ddim_step(const ag::Tensor& x_t, const ag::Tensor& noise_estimate, int t, int previous,
                                    bool clip) const {
  check_timestep(t, "NoiseSchedule::ddim_step");
  if (previous >= t || previous < -1)
    throw std::invalid_argument("NoiseSchedule::ddim_step: the previous timestep " + std::to_string(previous) +
                                " must be in [-1, " + std::to_string(t - 1) + "]");
  const double abar = alpha_bar(t);
  const double abar_previous = previous < 0 ? 1.0 : alpha_bar(previous);
  ag::Tensor x0 = (x_t - noise_estimate * std::sqrt(1.0 - abar)) * (1.0 / std::sqrt(abar));
  ag::Tensor eps = noise_estimate;
  if (clip) {
    x0 = ag::clamp(x0, -1.0, 1.0);
    eps = (x_t - x0 * std::sqrt(abar)) * (1.0 / std::sqrt(1.0 - abar));
  }
  return x0 * std::sqrt(abar_previous) + eps * std::sqrt(1.0 - abar_previous);
}

ag::Tensor NoiseSchedule::ddpm_step(const ag::Tensor& x_t, const ag::Tensor& noise_estimate, int t,
                                    const ag::Tensor& noise, bool clip) const {
  check_timestep(t, "NoiseSchedule::ddpm_step");
  const double abar = alpha_bar(t);
  const double abar_previous = t > 0 ? alpha_bar(t - 1) : 1.0;
  const double beta_t = beta(t);
  ag::Tensor x0 = (x_t - noise_estimate * std::sqrt(1.0 - abar)) * (1.0 / std::sqrt(abar));
  if (clip) x0 = ag::clamp(x0, -1.0, 1.0);
  const ag::Tensor mean = x0 * (std::sqrt(abar_previous) * beta_t / (1.0 - abar)) +
                          x_t * (std::sqrt(1.0 - beta_t) * (1.0 - abar_previous) / (1.0 - abar));
  if (t == 0) return mean;
  const double variance = std::max((1.0 - abar_previous) / (1.0 - abar) * beta_t, 1e-20);
  return mean + noise * std::sqrt(variance);
}

}  // namespace maps::diffusion
