#include "maps/diffusion/ddpm.h"

#include <stdexcept>
#include <string>

namespace maps::diffusion {

ag::Tensor denoising_loss(Denoiser& denoiser, const NoiseSchedule& schedule, const ag::Tensor& chunks,
                          const ag::Tensor& cond, ag::Generator& gen) {
  if (chunks.dim() != 3 || cond.dim() != 2 || cond.size(0) != chunks.size(0))
    throw std::invalid_argument("denoising_loss: expected chunks [batch, horizon, actions] and cond [batch, C], got " +
                                ag::to_string(chunks.shape()) + " and " + ag::to_string(cond.shape()));
  std::vector<int> steps(static_cast<std::size_t>(chunks.size(0)));
  for (int& t : steps) t = static_cast<int>(gen.next_u64() % static_cast<std::uint64_t>(schedule.training_steps()));
  const ag::Tensor noise = ag::randn(chunks.shape(), gen, chunks.dtype());
  const ag::Tensor noisy = schedule.add_noise(chunks.detach(), noise, steps);
  return ag::mse_loss(denoiser.forward(noisy, steps, cond), noise);
}

ag::Tensor sample_ddim(Denoiser& denoiser, const NoiseSchedule& schedule, const ag::Tensor& cond, std::int64_t horizon,
                       std::int64_t action_dim, int inference_steps, bool clip, ag::Generator& gen) {
  if (cond.dim() != 2 || horizon < 1 || action_dim < 1)
    throw std::invalid_argument("sample_ddim: expected cond [batch, C] and a positive horizon and action size, got " +
                                ag::to_string(cond.shape()) + ", " + std::to_string(horizon) + " and " +
                                std::to_string(action_dim));
  return sample_ddim_from(denoiser, schedule, cond, ag::randn({cond.size(0), horizon, action_dim}, gen, cond.dtype()),
                          inference_steps, clip);
}

ag::Tensor sample_ddim_from(Denoiser& denoiser, const NoiseSchedule& schedule, const ag::Tensor& cond,
                            const ag::Tensor& noise, int inference_steps, bool clip) {
  if (cond.dim() != 2 || noise.dim() != 3 || noise.size(0) != cond.size(0))
    throw std::invalid_argument("sample_ddim: expected cond [batch, C] and noise [batch, horizon, actions], got " +
                                ag::to_string(cond.shape()) + " and " + ag::to_string(noise.shape()));
  ag::NoGradGuard no_grad;
  const auto steps = schedule.ddim_timesteps(inference_steps);
  ag::Tensor x = noise;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const int previous = i + 1 < steps.size() ? steps[i + 1] : -1;
    const std::vector<int> at(static_cast<std::size_t>(cond.size(0)), steps[i]);
    x = schedule.ddim_step(x, denoiser.forward(x, at, cond), steps[i], previous, clip);
  }
  return x;
}

}  // namespace maps::diffusion
