#include "nn/functional.h"

#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "autograd/kernels.h"

namespace maps::nn::functional {

ag::Tensor layer_norm(const ag::Tensor& x, std::int64_t normalized_dims, double eps) {
  if (normalized_dims < 1 || normalized_dims > x.dim())
    throw std::invalid_argument("layer_norm: normalized_dims " + std::to_string(normalized_dims) + " is not in [1, " +
                                std::to_string(x.dim()) + "] for x of shape " + ag::shape_text(x));
  if (!(eps > 0.0)) throw std::invalid_argument("layer_norm: eps must be > 0, got " + std::to_string(eps));
  std::vector<std::int64_t> dims(static_cast<std::size_t>(normalized_dims));
  std::iota(dims.begin(), dims.end(), x.dim() - normalized_dims);
  const ag::Tensor centred = x - ag::mean(x, dims, true);
  const ag::Tensor variance = ag::mean(ag::square(centred), dims, true);
  return centred / ag::sqrt(variance + eps);
}

ag::Tensor group_norm(const ag::Tensor& x, std::int64_t groups, double eps) { return ag::group_norm(x, groups, eps); }

ag::Tensor conv1d(const ag::Tensor& x, const ag::Tensor& weight, const ag::Tensor& bias, std::int64_t padding) {
  return ag::conv1d(x, weight, bias, padding);
}

ag::Tensor downsample2(const ag::Tensor& x) {
  ag::detail::check_1d_layout(x, "downsample2", "x");
  const std::int64_t length = x.shape()[2];
  if (length % 2 != 0)
    throw std::invalid_argument("downsample2: the length must be even, got x of shape " + ag::shape_text(x));
  const ag::Tensor pairs = ag::reshape(x, {x.shape()[0], x.shape()[1], length / 2, 2});
  return ag::reshape(ag::narrow(pairs, 3, 0, 1), {x.shape()[0], x.shape()[1], length / 2});
}

ag::Tensor upsample2(const ag::Tensor& x) {
  ag::detail::check_1d_layout(x, "upsample2", "x");
  const ag::Shape& s = x.shape();
  return ag::reshape(ag::expand(ag::reshape(x, {s[0], s[1], s[2], 1}), {s[0], s[1], s[2], 2}), {s[0], s[1], 2 * s[2]});
}

ag::Tensor sinusoidal_embedding(const std::vector<double>& timesteps, std::int64_t dim, ag::Dtype dtype) {
  if (dim < 4 || dim % 2 != 0)
    throw std::invalid_argument("sinusoidal_embedding: dim must be even and at least 4, got " + std::to_string(dim));
  const std::int64_t half = dim / 2;
  const double scale = std::log(10000.0) / static_cast<double>(half - 1);
  std::vector<double> values(timesteps.size() * static_cast<std::size_t>(dim));
  for (std::size_t b = 0; b < timesteps.size(); ++b) {
    if (!std::isfinite(timesteps[b]))
      throw std::invalid_argument("sinusoidal_embedding: timestep " + std::to_string(b) + " is not finite");
    for (std::int64_t i = 0; i < half; ++i) {
      const double angle = timesteps[b] * std::exp(-scale * static_cast<double>(i));
      values[b * static_cast<std::size_t>(dim) + static_cast<std::size_t>(i)] = std::sin(angle);
      values[b * static_cast<std::size_t>(dim) + static_cast<std::size_t>(half + i)] = std::cos(angle);
    }
  }
  return ag::from_vector(values, {static_cast<std::int64_t>(timesteps.size()), dim}, dtype);
}

}  // namespace maps::nn::functional
