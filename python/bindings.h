#pragma once

#include <pybind11/pybind11.h>

#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "autograd/autograd.h"

// The parts of the `maps` Python module (python/maps/__init__.py wraps them): one function per layer it exposes.
namespace maps::python {

void bind_autograd(pybind11::module_& m);  // Tensor, indexing, ops, grad, gradcheck, grad mode, Generator
void bind_nn(pybind11::module_& m);        // _maps.nn: modules, save/load, init; _maps.optim: Adam, SGD
void bind_envs(pybind11::module_& m);      // task sets, envs, experts
void bind_demos(pybind11::module_& m);     // demo files
void bind_runs(pybind11::module_& m);      // trained runs: act, selector scores, parameters, forward
void bind_training(pybind11::module_& m);  // SelectorLoss, Policy, their registration, maps.train
// Every part, in order (the extension module, and the tool's embedded interpreter: python/embed.cpp).
void bind_all(pybind11::module_& m);

// A config's Python plugin run in the running interpreter (maps._load_plugin_file: its registrations, recorded for
// provenance), Python's error as a std::runtime_error; defined in bind_training.cpp. The tool starts its
// interpreter first (python/embed.cpp).
void run_python_plugin_file(const std::string& path);

// ----- shared by the parts (defined in bind_autograd.cpp) -----

// "float32" | "float64"; anything else is a ValueError naming it.
ag::Dtype parse_dtype(const std::string& name);
// A numpy array, nested list, number or maps.Tensor as a new tensor (a copy): float32 stays float32 unless `dtype`
// says otherwise, everything else becomes float64.
ag::Tensor tensor_from_python(const pybind11::object& data, const std::optional<std::string>& dtype,
                              bool requires_grad);
// The generator factories and layers draw from when given none (maps.manual_seed seeds it).
ag::Generator& default_generator();
// `generator`, or the default one when it is null (a `generator=None` argument).
inline ag::Generator& generator_or_default(ag::Generator* generator) {
  return generator != nullptr ? *generator : default_generator();
}

// A shared_ptr to the C++ object of a Python object bound with a std::shared_ptr holder (nn::Module and its
// subclasses) that also keeps the Python object alive for as long as C++ holds the pointer. Use it wherever C++
// keeps a module it was given from Python (a child, a Sequential's entry, a training loss): an instance of a Python
// subclass (maps.nn.Module subclassed in Python) lives half in Python (its forward, its attributes), and pybind11's
// classic holder would otherwise let that half die with the last Python reference while C++ still calls it.
template <typename T>
std::shared_ptr<T> keep_python_alive(const pybind11::object& object) {
  std::shared_ptr<T> held = object.cast<std::shared_ptr<T>>();
  std::shared_ptr<void> guard(new pybind11::object(object), [](void* kept) {
    pybind11::gil_scoped_acquire gil;
    delete static_cast<pybind11::object*>(kept);
  });
  return std::shared_ptr<T>(std::move(guard), held.get());  // aliasing: owns the Python object, points at T
}

}  // namespace maps::python
