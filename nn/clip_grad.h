#pragma once

#include <vector>

#include "autograd/autograd.h"

namespace maps::nn {

// torch.nn.utils.clip_grad_norm_ with norm_type 2: the 2-norm of all gradients taken together (parameters
// without a grad are skipped) is returned; when it exceeds max_norm, every grad is scaled in place by
// max_norm / (total + 1e-6). Throws when max_norm is negative or not finite. A non-finite total is returned
// as is (and scales the grads to NaN, as PyTorch does), so callers can detect it.
double clip_grad_norm_(const std::vector<ag::Tensor>& parameters, double max_norm);

// The 2-norm of all gradients taken together, without changing them.
double grad_norm(const std::vector<ag::Tensor>& parameters);

}  // namespace maps::nn
