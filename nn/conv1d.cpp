#include "nn/conv1d.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "nn/functional.h"
#include "nn/init.h"

namespace maps::nn {

Conv1d::Conv1d(std::int64_t in_channels, std::int64_t out_channels, std::int64_t kernel, std::int64_t padding,
               ag::Generator& gen, bool bias)
    : UnaryModule("Conv1d"), in_(in_channels), out_(out_channels), kernel_(kernel), padding_(padding), has_bias_(bias) {
  if (in_channels <= 0 || out_channels <= 0 || kernel <= 0 || padding < 0)
    throw std::invalid_argument("Conv1d: channels and kernel must be positive and padding >= 0, got in " +
                                std::to_string(in_channels) + ", out " + std::to_string(out_channels) + ", kernel " +
                                std::to_string(kernel) + ", padding " + std::to_string(padding));
  weight_ = register_parameter("weight", ag::zeros({out_, in_, kernel_}));
  if (has_bias_) bias_ = register_parameter("bias", ag::zeros({out_}));
  ag::Tensor w = parameter_at(weight_);
  init::kaiming_uniform_(w, gen, std::sqrt(5.0));
  if (has_bias_) {
    const double bound = 1.0 / std::sqrt(static_cast<double>(in_ * kernel_));
    ag::Tensor b = parameter_at(bias_);
    init::uniform_(b, -bound, bound, gen);
  }
}

ag::Tensor Conv1d::forward(const ag::Tensor& x) {
  return functional::conv1d(x, weight(), has_bias_ ? parameter_at(bias_) : ag::Tensor(), padding_);
}

}  // namespace maps::nn
