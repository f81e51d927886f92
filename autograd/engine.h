#pragma once

#include <optional>
#include <vector>

#include "autograd/tensor.h"

namespace maps::ag {

// Like torch::autograd::backward: accumulates d(outputs)/d(leaf) into each leaf's grad().
// A missing grad_output is allowed only for a one-element output (it is taken as 1).
// retain_graph defaults to create_graph; without it the graph's saved tensors are freed and a
// second pass through the same graph is an error. With create_graph a leaf's grad() holds a graph
// that leads back to the leaf (a reference cycle, as in PyTorch): clear it with set_grad(Tensor())
// or Module::zero_grad() when done. grad(..., create_graph) stores nothing and has no such cycle.
void backward(const std::vector<Tensor>& outputs, const std::vector<Tensor>& grad_outputs = {},
              std::optional<bool> retain_graph = std::nullopt, bool create_graph = false);

// Like torch::autograd::grad: returns d(outputs)/d(inputs) (vector-Jacobian products with
// grad_outputs) without touching any grad(). Inputs may be leaves or intermediate tensors.
// With create_graph the returned gradients carry a graph, so they can be differentiated again
// (second order, as MAML needs). An input the outputs do not depend on is an error unless
// allow_unused, where its gradient is an undefined Tensor.
std::vector<Tensor> grad(const std::vector<Tensor>& outputs, const std::vector<Tensor>& inputs,
                         const std::vector<Tensor>& grad_outputs = {}, std::optional<bool> retain_graph = std::nullopt,
                         bool create_graph = false, bool allow_unused = false);

}  // namespace maps::ag
