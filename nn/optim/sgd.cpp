#include "nn/optim/sgd.h"

#include <stdexcept>
#include <string>

namespace maps::optim {

namespace {

void check_options(const SGDOptions& o) {
  auto fail = [](const std::string& what, double value) {
    throw std::invalid_argument("SGD: invalid " + what + ": " + std::to_string(value));
  };
  if (!(o.lr >= 0.0)) fail("learning rate (must be >= 0)", o.lr);
  if (!(o.momentum >= 0.0)) fail("momentum (must be >= 0)", o.momentum);
  if (!(o.weight_decay >= 0.0)) fail("weight_decay (must be >= 0)", o.weight_decay);
  if (o.nesterov && (o.momentum <= 0.0 || o.dampening != 0.0))
    throw std::invalid_argument("SGD: nesterov momentum requires momentum > 0 and zero dampening");
}

}  // namespace

SGD::SGD(std::vector<ag::Tensor> params, const SGDOptions& options)
    : Optimizer(std::move(params), "SGD"), options_(options), momentum_buffers_(params_.size()) {
  check_options(options_);
}

void SGD::set_lr(double lr) {
  SGDOptions changed = options_;
  changed.lr = lr;
  check_options(changed);
  options_ = changed;
}

void SGD::step() {
  ag::NoGradGuard no_grad;
  const SGDOptions& o = options_;
  for (std::size_t i = 0; i < params_.size(); ++i) {
    const ag::Tensor grad = checked_grad(i);
    if (!grad.defined()) continue;
    ag::Tensor& param = params_[i];
    ag::Tensor& buffer = momentum_buffers_[i];
    const bool first = o.momentum != 0.0 && !buffer.defined();
    if (first) buffer = ag::zeros(param.shape(), param.dtype());
    param.bump_version();  // an in-place update: a graph that saved the old values must not use the new ones

    ag::dispatch_dtype(param.dtype(), [&](auto tag) {
      using T = typename decltype(tag)::type;
      auto p = param.array<T>();
      auto g = grad.array<T>();
      const T lr = static_cast<T>(o.lr), wd = static_cast<T>(o.weight_decay);
      // d = g + wd p, written out in each branch so nothing is allocated.
      if (o.momentum == 0.0) {
        p -= lr * (g + wd * p);
        return;
      }
      auto buf = buffer.array<T>();
      const T mu = static_cast<T>(o.momentum), keep = static_cast<T>(1.0 - o.dampening);
      if (first) {
        buf = g + wd * p;
      } else {
        buf = mu * buf + keep * (g + wd * p);
      }
      if (o.nesterov) {
        p -= lr * ((g + wd * p) + mu * buf);
      } else {
        p -= lr * buf;
      }
    });
  }
}

}  // namespace maps::optim
