#pragma once

// The layers of a diffusion policy's denoiser (issue 46) as functions, built from autograd's ops: their gradients,
// second order included, are those ops'. Shapes follow PyTorch's (channels before positions for the 1-D ones).

#include <cstdint>
#include <vector>

#include "autograd/autograd.h"

namespace maps::nn::functional {

// x normalised over its last `normalized_dims` dims: (x - mean) / sqrt(var + eps), var the biased variance (as
// torch.nn.functional.layer_norm, without its affine part, which LayerNorm adds).
ag::Tensor layer_norm(const ag::Tensor& x, std::int64_t normalized_dims = 1, double eps = 1e-5);

// x [B, C, ...]: each of `groups` groups of C / groups channels normalised over its channels and positions together
// (torch.nn.functional.group_norm without the affine part). C must divide by groups. One op: ag::group_norm.
ag::Tensor group_norm(const ag::Tensor& x, std::int64_t groups, double eps = 1e-5);

// x [B, C_in, L] convolved with weight [C_out, C_in, K] (cross-correlation, as PyTorch), `padding` zeros on each side,
// stride 1: [B, C_out, L + 2 padding - K + 1]; bias [C_out] or an undefined tensor. One op: ag::conv1d.
ag::Tensor conv1d(const ag::Tensor& x, const ag::Tensor& weight, const ag::Tensor& bias, std::int64_t padding);

// Positions 0, 2, 4, ... of x [B, C, L], L even: a stride-2 convolution is conv1d then this.
ag::Tensor downsample2(const ag::Tensor& x);

// Each position of x [B, C, L] twice: [B, C, 2 L] (nearest-neighbour upsampling).
ag::Tensor upsample2(const ag::Tensor& x);

// Diffusion Policy's embedding of the denoising step: row b is [sin(t_b f_0) .. sin(t_b f_{h-1}), cos(t_b f_0) ..
// cos(t_b f_{h-1})] with h = dim / 2 and f_i = exp(-ln(10000) i / (h - 1)); dim even and at least 4. A constant (no
// gradient).
ag::Tensor sinusoidal_embedding(const std::vector<double>& timesteps, std::int64_t dim,
                                ag::Dtype dtype = ag::Dtype::Float32);

}  // namespace maps::nn::functional
