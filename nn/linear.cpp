#include "nn/linear.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "nn/init.h"

namespace maps::nn {

Linear::Linear(std::int64_t in_features, std::int64_t out_features, ag::Generator& gen, bool bias)
    : UnaryModule("Linear"), in_(in_features), out_(out_features), has_bias_(bias) {
  if (in_features <= 0 || out_features <= 0)
    throw std::invalid_argument("Linear: in_features and out_features must be positive, got " +
                                std::to_string(in_features) + " and " + std::to_string(out_features));
  weight_ = register_parameter("weight", ag::zeros({out_, in_}));
  if (has_bias_) bias_ = register_parameter("bias", ag::zeros({out_}));
  reset_parameters(gen);
}

const ag::Tensor& Linear::bias() const {
  if (!has_bias_) throw std::logic_error("Linear::bias: this Linear was built without bias");
  return parameter_at(bias_);
}

void Linear::reset_parameters(ag::Generator& gen) {
  ag::Tensor w = weight();
  init::kaiming_uniform_(w, gen, std::sqrt(5.0));
  if (has_bias_) {
    const double bound = 1.0 / std::sqrt(static_cast<double>(in_));
    ag::Tensor b = bias();
    init::uniform_(b, -bound, bound, gen);
  }
}

ag::Tensor Linear::forward(const ag::Tensor& x) { return forward_activated(x, Activation::Identity); }

ag::Tensor Linear::forward_activated(const ag::Tensor& x, Activation activation) {
  if (!x.defined() || (x.dim() != 2 && x.dim() != 3) || x.size(-1) != in_)
    throw std::invalid_argument("Linear(" + std::to_string(in_) + ", " + std::to_string(out_) +
                                ")::forward: expected input [batch, " + std::to_string(in_) + "] or [b, n, " +
                                std::to_string(in_) + "], got " + ag::shape_text(x));
  const ag::Tensor b = has_bias_ ? bias() : ag::Tensor();
  if (const auto fused = fused_activation(activation)) return ag::linear(x, weight(), b, *fused);
  return apply_activation(activation, ag::linear(x, weight(), b));
}

}  // namespace maps::nn
