#include "nn/optim/adam.h"

#include <algorithm>
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
    : Optimizer(std::move(params), "Adam"), options_(options), state_(params_.size()), lr_scales_(params_.size(), 1.0) {
  check_options(options_);
}

void Adam::set_lr_scale(std::size_t i, double scale) {
  if (i >= lr_scales_.size())
    throw std::out_of_range("Adam: parameter " + std::to_string(i) + " of " + std::to_string(lr_scales_.size()));
  if (!(scale >= 0.0) || !std::isfinite(scale))
    throw std::invalid_argument("Adam: invalid learning-rate scale (must be finite and >= 0): " +
                                std::to_string(scale));
  lr_scales_[i] = scale;
}

void Adam::set_lr(double lr) {
  AdamOptions changed = options_;
  changed.lr = lr;
  check_options(changed);
  options_ = changed;
}

nn::NamedTensors Adam::state() const {
  nn::NamedTensors out;
  for (std::size_t i = 0; i < state_.size(); ++i) {
    const State& s = state_[i];
    if (s.step == 0) continue;
    const std::string index = std::to_string(i);
    out.push_back({"step." + index, ag::scalar_tensor(static_cast<double>(s.step), ag::Dtype::Float64)});
    out.push_back({"exp_avg." + index, s.exp_avg.detach().clone()});
    out.push_back({"exp_avg_sq." + index, s.exp_avg_sq.detach().clone()});
  }
  return out;
}

void Adam::load_state(const nn::NamedTensors& tensors) {
  std::vector<State> loaded(params_.size());
  const auto find = [&](const std::string& name) -> const ag::Tensor* {
    for (const auto& t : tensors)
      if (t.name == name) return &t.tensor;
    return nullptr;
  };
  std::size_t used = 0;
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const std::string index = std::to_string(i);
    const ag::Tensor* step = find("step." + index);
    if (!step) continue;
    const ag::Tensor* m = find("exp_avg." + index);
    const ag::Tensor* v = find("exp_avg_sq." + index);
    for (const auto& [name, t] : {std::pair{"exp_avg." + index, m}, std::pair{"exp_avg_sq." + index, v}}) {
      if (!t || t->shape() != params_[i].shape() || t->dtype() != params_[i].dtype())
        throw std::invalid_argument("Adam state: '" + name + "' is missing or does not match parameter " + index +
                                    "'s shape and dtype");
    }
    const double count = step->numel() == 1 ? step->item() : -1.0;
    // 2^53: past it a double skips whole numbers, and far past it the cast to int64 below is undefined.
    if (!(count >= 1.0) || count > 9007199254740992.0 || count != std::floor(count))
      throw std::invalid_argument("Adam state: 'step." + index + "' must be a whole number in [1, 2^53]");
    // An infinite second moment would freeze its parameter for good (m / inf = 0) without a word.
    const auto check_moment = [](const std::string& name, const ag::Tensor& t, bool non_negative) {
      for (const double value : t.to_vector())
        if (!std::isfinite(value) || (non_negative && value < 0.0))
          throw std::invalid_argument("Adam state: '" + name + "' must hold finite values" +
                                      (non_negative ? " >= 0" : "") + ", got " + std::to_string(value));
    };
    check_moment("exp_avg." + index, *m, false);
    check_moment("exp_avg_sq." + index, *v, true);
    loaded[i].step = static_cast<std::int64_t>(count);
    loaded[i].exp_avg = m->detach().clone();
    loaded[i].exp_avg_sq = v->detach().clone();
    used += 3;
  }
  if (used != tensors.size())
    throw std::invalid_argument("Adam state: " + std::to_string(tensors.size() - used) +
                                " entries name no parameter of this optimiser (" + std::to_string(params_.size()) +
                                " parameters)");
  state_ = std::move(loaded);
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
    param.bump_version();  // an in-place update: a graph that saved the old values must not use the new ones
    const double t = static_cast<double>(s.step);
    const double bias_correction1 = 1.0 - std::pow(o.beta1, t);
    const double bias_correction2_sqrt = std::sqrt(1.0 - std::pow(o.beta2, t));
    const double step_size = o.lr * lr_scales_[i] / bias_correction1;  // lr * 1.0 is lr exactly

    ag::dispatch_dtype(param.dtype(), [&](auto tag) {
      using T = typename decltype(tag)::type;
      T* p = param.data<T>();
      const T* g = grad.data<T>();
      T* m = s.exp_avg.data<T>();
      T* v = s.exp_avg_sq.data<T>();
      const T b1 = static_cast<T>(o.beta1), one_minus_b1 = static_cast<T>(1.0 - o.beta1);
      const T b2 = static_cast<T>(o.beta2), one_minus_b2 = static_cast<T>(1.0 - o.beta2);
      const T decay = static_cast<T>(o.weight_decay), step = static_cast<T>(step_size);
      const T correction = static_cast<T>(bias_correction2_sqrt), eps = static_cast<T>(o.eps);
      // The three updates chunk by chunk, so each chunk of the four arrays is read from memory once, in PyTorch's
      // order of operations (addcmul is (value * g) * g): the Release build matches it bit for bit.
      using Array = Eigen::Array<T, Eigen::Dynamic, 1>;
      constexpr std::int64_t kChunk = 2048;
      ag::parallel_for((param.numel() + kChunk - 1) / kChunk, 8, [&](std::int64_t c0, std::int64_t c1) {
        for (std::int64_t begin = c0 * kChunk; begin < std::min(param.numel(), c1 * kChunk); begin += kChunk) {
          const std::int64_t n = std::min(kChunk, param.numel() - begin);
          Eigen::Map<Array> pc(p + begin, n), mc(m + begin, n), vc(v + begin, n);
          const Eigen::Map<const Array> gc(g + begin, n);
          auto update_moments = [&](const auto& gd) {
            mc = b1 * mc + one_minus_b1 * gd;
            vc = b2 * vc + (one_minus_b2 * gd) * gd;
          };
          if (o.weight_decay != 0.0) {
            update_moments(gc + decay * pc);
          } else {
            update_moments(gc);
          }
          pc -= step * mc / (vc.sqrt() / correction + eps);
        }
      });
    });
  }
}

}  // namespace maps::optim
