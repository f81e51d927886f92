#pragma once

#include <pybind11/pybind11.h>

// The parts of the `maps` Python module (python/maps/__init__.py wraps them): one function per layer it exposes.
namespace maps::python {

void bind_autograd(pybind11::module_& m);  // Tensor, grad, gradcheck, grad mode
void bind_envs(pybind11::module_& m);      // task sets, envs, experts
void bind_demos(pybind11::module_& m);     // demo files
void bind_runs(pybind11::module_& m);      // trained runs: act, selector scores

}  // namespace maps::python
