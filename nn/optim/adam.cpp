#include "nn/optim/adam.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace maps::optim {

namespace {

void check_options(const AdamOptions& o) {
  auto fail = [](const std::string& what, double value) {
    throw std::invalid_argument("Adam: invalid " + what + ": " + std::to_string(value));
  };
  if (!(o.lr >= 0.0)) fail("learning rate (must be >= 0)", o.lr);
  if (!(o.eps >= 0.0)) fail("epsilon (must be >= 0)", o.eps);
  if (!(o.beta1 >= 0.0 && o.beta1 < 1.0)) fail("beta1 (must be in [0, 1))", o.beta1);
  if (!(o.beta2 >= 0.0 && o.beta2 < 1.0)) fail("beta2 (must be in [0, 1))", o.beta2);
  if (!(o.weight_decay >= 0.0)) fail("weight_decay (must be >= 0)", o.weight_decay);
}

}  // namespace

Adam::Adam(std::vector<ag::Tensor> params, const AdamOptions& options)
    : Optimizer(std::move(params), "Adam"), options_(options), state_(params_.size()) {
  check_options(options_);
}

void Adam::set_lr(double lr) {
  AdamOptions changed = options_;
  changed.lr = lr;
  check_options(changed);
  options_ = changed;
}

void Adam::step() {
  ag::NoGradGuard no_grad;
  const AdamOptions& o = options_;
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const ag::Tensor grad = checked_grad(i);
    if (!grad.defined()) continue;
    ag::Tensor& param = params_[i];
    State& s = state_[i];
    if (!s.exp_avg.defined()) {
      s.exp_avg = ag::zeros(param.shape(), param.dtype());
      s.exp_avg_sq = ag::zeros(param.shape(), param.dtype());
    }
    s.step += 1;
    const double t = static_cast<double>(s.step);
    const double bias_correction1 = 1.0 - std::pow(o.beta1, t);
    const double bias_correction2_sqrt = std::sqrt(1.0 - std::pow(o.beta2, t));
    const double step_size = o.lr / bias_correction1;

    ag::dispatch_dtype(param.dtype(), [&](auto tag) {
      using T = typename decltype(tag)::type;
      auto p = param.array<T>();
      auto g = grad.array<T>();
      auto m = s.exp_avg.array<T>();
      auto v = s.exp_avg_sq.array<T>();
      const T b1 = static_cast<T>(o.beta1), one_minus_b1 = static_cast<T>(1.0 - o.beta1);
      const T b2 = static_cast<T>(o.beta2), one_minus_b2 = static_cast<T>(1.0 - o.beta2);
      // PyTorch's order of operations (addcmul is (value * g) * g): the Release build matches it bit for bit.
      auto update_moments = [&](const auto& gd) {
        m = b1 * m + one_minus_b1 * gd;
        v = b2 * v + (one_minus_b2 * gd) * gd;
      };
      if (o.weight_decay != 0.0) {
        update_moments(g + static_cast<T>(o.weight_decay) * p);
      } else {
        update_moments(g);
      }
      p -= static_cast<T>(step_size) * m / (v.sqrt() / static_cast<T>(bias_correction2_sqrt) + static_cast<T>(o.eps));
    });
  }
}

}  // namespace maps::optim
