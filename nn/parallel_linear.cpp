#include "nn/parallel_linear.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "nn/init.h"

namespace maps::nn {

ParallelLinear::ParallelLinear(std::int64_t members, std::int64_t in_features, std::int64_t out_features,
                               ag::Generator& gen, bool bias)
    : UnaryModule("ParallelLinear"), members_(members), in_(in_features), out_(out_features), has_bias_(bias) {
  if (members <= 0 || in_features <= 0 || out_features <= 0)
    throw std::invalid_argument("ParallelLinear: members, in_features and out_features must be positive, got " +
                                std::to_string(members) + ", " + std::to_string(in_features) + ", " +
                                std::to_string(out_features));
  weight_ = register_parameter("weight", ag::zeros({members_, in_, out_}));
  if (has_bias_) bias_ = register_parameter("bias", ag::zeros({members_, 1, out_}));
  reset_parameters(gen);
}

const ag::Tensor& ParallelLinear::bias() const {
  if (!has_bias_) throw std::logic_error("ParallelLinear::bias: this ParallelLinear was built without bias");
  return parameter_at(bias_);
}

void ParallelLinear::reset_parameters(ag::Generator& gen) {
  ag::NoGradGuard no_grad;
  // The same expressions as Linear (kaiming_uniform_ with a = sqrt(5), then 1/sqrt(in)), so values match bit for bit.
  const double w_bound = init::calculate_gain("leaky_relu", std::sqrt(5.0)) * std::sqrt(3.0 / static_cast<double>(in_));
  const double b_bound = 1.0 / std::sqrt(static_cast<double>(in_));
  ag::Tensor w = weight();
  ag::Tensor b = has_bias_ ? bias() : ag::Tensor();
  w.bump_version();
  if (has_bias_) b.bump_version();
  ag::dispatch_dtype(w.dtype(), [&](auto tag) {
    using T = typename decltype(tag)::type;
    T* wd = w.data<T>();
    T* bd = has_bias_ ? b.data<T>() : nullptr;
    for (std::int64_t m = 0; m < members_; ++m) {
      T* wm = wd + m * in_ * out_;
      // Linear's weight is [out, in] drawn row-major; slice m stores its transpose [in, out].
      for (std::int64_t o = 0; o < out_; ++o)
        for (std::int64_t i = 0; i < in_; ++i) wm[i * out_ + o] = static_cast<T>(gen.uniform(-w_bound, w_bound));
      if (bd != nullptr)
        for (std::int64_t o = 0; o < out_; ++o) bd[m * out_ + o] = static_cast<T>(gen.uniform(-b_bound, b_bound));
    }
  });
}

ag::Tensor ParallelLinear::forward(const ag::Tensor& x) { return forward_activated(x, Activation::Identity); }

ag::Tensor ParallelLinear::forward_activated(const ag::Tensor& x, Activation activation) {
  const bool shared = x.defined() && x.dim() == 2 && x.size(1) == in_;
  const bool batched = x.defined() && x.dim() == 3 && x.size(0) == members_ && x.size(2) == in_;
  if (!shared && !batched)
    throw std::invalid_argument("ParallelLinear(" + std::to_string(members_) + ", " + std::to_string(in_) + ", " +
                                std::to_string(out_) + ")::forward: expected input [" + std::to_string(members_) +
                                ", batch, " + std::to_string(in_) + "] or [batch, " + std::to_string(in_) + "], got " +
                                ag::shape_text(x));
  const ag::Tensor b = has_bias_ ? bias() : ag::Tensor();
  if (const auto fused = fused_activation(activation)) return ag::parallel_linear(x, weight(), b, *fused);
  return apply_activation(activation, ag::parallel_linear(x, weight(), b));
}

}  // namespace maps::nn
