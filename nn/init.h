#pragma once

#include <cstdint>
#include <string>
#include <utility>

#include "autograd/autograd.h"

// In-place initialisers after torch.nn.init. Each writes every element of `tensor` under a NoGradGuard (so it
// may be a leaf that requires grad) and returns it. Random ones draw from `gen` in row-major order, so the
// same seed gives the same values.
namespace maps::nn::init {

enum class FanMode { FanIn, FanOut };

// PyTorch's _calculate_fan_in_and_fan_out: for shape [out, in, k...], fan_in = in * prod(k), fan_out = out *
// prod(k). Throws for tensors with fewer than 2 dims.
std::pair<std::int64_t, std::int64_t> fan_in_and_fan_out(const ag::Tensor& tensor);

// Recommended gain: "linear"/"sigmoid" 1, "tanh" 5/3, "relu" sqrt(2), "leaky_relu" sqrt(2/(1+param^2)).
double calculate_gain(const std::string& nonlinearity, double param = 0.01);

ag::Tensor& uniform_(ag::Tensor& tensor, double low, double high, ag::Generator& gen);
ag::Tensor& normal_(ag::Tensor& tensor, double mean, double std, ag::Generator& gen);
ag::Tensor& constant_(ag::Tensor& tensor, double value);
ag::Tensor& zeros_(ag::Tensor& tensor);
ag::Tensor& ones_(ag::Tensor& tensor);

// U(-bound, bound), bound = gain * sqrt(3 / fan), gain = sqrt(2 / (1 + a^2)) (leaky_relu). With a = sqrt(5)
// (what Linear uses) the bound is 1/sqrt(fan_in).
ag::Tensor& kaiming_uniform_(ag::Tensor& tensor, ag::Generator& gen, double a = 0.0, FanMode mode = FanMode::FanIn);
// U(-bound, bound), bound = gain * sqrt(6 / (fan_in + fan_out)).
ag::Tensor& xavier_uniform_(ag::Tensor& tensor, ag::Generator& gen, double gain = 1.0);

// A (semi-)orthogonal matrix times gain: rows = size(0), cols = numel / rows; Q of the QR decomposition of a
// standard normal [rows, cols] matrix (transposed when rows < cols), with Q's columns multiplied by the signs
// of R's diagonal, as torch.nn.init.orthogonal_. Then W W^T = gain^2 I (rows <= cols) or W^T W = gain^2 I.
ag::Tensor& orthogonal_(ag::Tensor& tensor, double gain, ag::Generator& gen);

}  // namespace maps::nn::init
