#include "nn/clip_grad.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace maps::nn {

double grad_norm(const std::vector<ag::Tensor>& parameters) {
  double sum_sq = 0.0;
  for (const auto& p : parameters) {
    if (!p.defined()) continue;
    const ag::Tensor g = p.grad();
    if (!g.defined()) continue;
    ag::dispatch_dtype(g.dtype(), [&](auto tag) {
      using T = typename decltype(tag)::type;
      sum_sq += g.array<T>().template cast<double>().square().sum();
    });
  }
  return std::sqrt(sum_sq);
}

double clip_grad_norm_(const std::vector<ag::Tensor>& parameters, double max_norm) {
  if (!(max_norm >= 0.0) || !std::isfinite(max_norm))
    throw std::invalid_argument("clip_grad_norm_: max_norm must be finite and >= 0, got " + std::to_string(max_norm));
  const double total = grad_norm(parameters);
  const double coef = max_norm / (total + 1e-6);
  if (coef < 1.0 || std::isnan(coef)) {
    ag::NoGradGuard no_grad;
    for (const auto& p : parameters) {
      if (!p.defined()) continue;
      ag::Tensor g = p.grad();
      if (!g.defined()) continue;
      g.bump_version();
      ag::dispatch_dtype(g.dtype(), [&](auto tag) {
        using T = typename decltype(tag)::type;
        g.array<T>() *= static_cast<T>(coef);
      });
    }
  }
  return total;
}

}  // namespace maps::nn
