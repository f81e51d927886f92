#pragma once

#include <cstdint>

#include "maps/policies/maps_policy.h"

namespace maps::core {

// The floating-point operations of the matrix products in one MAPS training step (forward, backward; the products
// only: elementwise work, softmax and Adam are a few percent and not counted), for a balanced batch of per_task
// states of each of the K tasks. A product of [r, i] by [i, o] counts 2 r i o. The count is of the work the step
// needs, whatever a kernel does beyond it:
//   modules:  forward 2 n M sum(in o); backward the weight gradients (the same) and the input gradients of every
//             layer but the first (the observations need none);
//   head:     per module [n, F] x [F, A]: forward, weight and feature gradients;
//   selector: the (K + 1) n rows it scores (every state under every task for the share loss, plus the previous
//             states for the smooth loss): its first layer's state part once per distinct state (2n rows: the
//             task part of a one-hot input is a row lookup), the other layers on every row, forward and both
//             gradients (the first layer's weight gradient only).
double maps_training_step_flops(const PolicyShape& shape, const MAPSConfig& config, std::int64_t per_task);

}  // namespace maps::core
