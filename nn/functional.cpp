#include "nn/functional.h"

#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

namespace maps::nn::functional {

namespace {

std::string shape_text(const ag::Tensor& x) { return ag::to_string(x.shape()); }

void require_1d_layout(const ag::Tensor& x, const char* op) {
  if (x.dim() != 3)
    throw std::invalid_argument(std::string(op) + ": expected x of shape [batch, channels, length], got " +
                                shape_text(x));
}

}  // namespace

ag::Tensor layer_norm(const ag::Tensor& x, std::int64_t normalized_dims, double eps) {
  if (normalized_dims < 1 || normalized_dims > x.dim())
    throw std::invalid_argument("layer_norm: normalized_dims " + std::to_string(normalized_dims) + " is not in [1, " +
                                std::to_string(x.dim()) + "] for x of shape " + shape_text(x));
  if (!(eps > 0.0)) throw std::invalid_argument("layer_norm: eps must be > 0, got " + std::to_string(eps));
  std::vector<std::int64_t> dims(static_cast<std::size_t>(normalized_dims));
  std::iota(dims.begin(), dims.end(), x.dim() - normalized_dims);
  const ag::Tensor centred = x - ag::mean(x, dims, true);
  const ag::Tensor variance = ag::mean(ag::square(centred), dims, true);
  return centred / ag::sqrt(variance + eps);
}

ag::Tensor group_norm(const ag::Tensor& x, std::int64_t groups, double eps) {
  if (x.dim() < 2)
    throw std::invalid_argument("group_norm: expected x of shape [batch, channels, ...], got " + shape_text(x));
  const std::int64_t channels = x.shape()[1];
  if (groups < 1 || channels % groups != 0)
    throw std::invalid_argument("group_norm: " + std::to_string(channels) + " channels do not split into " +
                                std::to_string(groups) + " groups");
  const ag::Tensor grouped = ag::reshape(x, {x.shape()[0], groups, -1});
  return ag::reshape(layer_norm(grouped, 1, eps), x.shape());
}

ag::Tensor conv1d(const ag::Tensor& x, const ag::Tensor& weight, const ag::Tensor& bias, std::int64_t padding) {
  require_1d_layout(x, "conv1d");
  if (weight.dim() != 3 || weight.shape()[1] != x.shape()[1])
    throw std::invalid_argument("conv1d: expected weight of shape [out, " + std::to_string(x.shape()[1]) +
                                ", kernel] for x of shape " + shape_text(x) + ", got " + shape_text(weight));
  if (padding < 0) throw std::invalid_argument("conv1d: padding must be >= 0, got " + std::to_string(padding));
  const std::int64_t batch = x.shape()[0], in = x.shape()[1], length = x.shape()[2];
  const std::int64_t out = weight.shape()[0], kernel = weight.shape()[2];
  const std::int64_t out_length = length + 2 * padding - kernel + 1;
  if (out_length < 1)
    throw std::invalid_argument("conv1d: a kernel of " + std::to_string(kernel) + " is longer than the padded length " +
                                std::to_string(length + 2 * padding));
  ag::Tensor padded = x;
  if (padding > 0) {
    const ag::Tensor zeros = ag::zeros({batch, in, padding}, x.dtype());
    padded = ag::concat({zeros, x, zeros}, 2);
  }
  // The K shifted windows side by side ([B, C_in, K, L_out]), then one product with the weight as [C_out, C_in K].
  std::vector<ag::Tensor> windows;
  windows.reserve(static_cast<std::size_t>(kernel));
  for (std::int64_t k = 0; k < kernel; ++k) windows.push_back(ag::narrow(padded, 2, k, out_length));
  const ag::Tensor columns =
      ag::reshape(ag::transpose(ag::reshape(ag::stack(windows, 2), {batch, in * kernel, out_length}), 1, 2),
                  {batch * out_length, in * kernel});
  const ag::Tensor product = ag::linear(columns, ag::reshape(weight, {out, in * kernel}), bias);
  return ag::transpose(ag::reshape(product, {batch, out_length, out}), 1, 2);
}

ag::Tensor downsample2(const ag::Tensor& x) {
  require_1d_layout(x, "downsample2");
  const std::int64_t length = x.shape()[2];
  if (length % 2 != 0)
    throw std::invalid_argument("downsample2: the length must be even, got x of shape " + shape_text(x));
  const ag::Tensor pairs = ag::reshape(x, {x.shape()[0], x.shape()[1], length / 2, 2});
  return ag::reshape(ag::narrow(pairs, 3, 0, 1), {x.shape()[0], x.shape()[1], length / 2});
}

ag::Tensor upsample2(const ag::Tensor& x) {
  require_1d_layout(x, "upsample2");
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
