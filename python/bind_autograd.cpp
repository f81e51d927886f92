#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "python/bindings.h"

namespace py = pybind11;

namespace maps::python {
namespace {

ag::Dtype parse_dtype(const std::string& name) {
  if (name == "float32") return ag::Dtype::Float32;
  if (name == "float64") return ag::Dtype::Float64;
  throw std::invalid_argument("dtype must be 'float32' or 'float64', not '" + name + "'");
}

template <typename T>
ag::Tensor tensor_from_array(const py::array_t<T, py::array::c_style | py::array::forcecast>& array) {
  ag::Shape shape(array.shape(), array.shape() + array.ndim());
  ag::Tensor tensor = ag::empty(shape, ag::dtype_of<T>());
  if (tensor.numel() > 0)
    std::memcpy(tensor.data<T>(), array.data(), sizeof(T) * static_cast<std::size_t>(tensor.numel()));
  return tensor;
}

// A numpy array (or anything numpy can make one of: lists, scalars) as a tensor; float32 input stays float32 unless
// a dtype says otherwise, everything else becomes float64 (the dtype of gradient checks).
ag::Tensor tensor_from_python(const py::object& data, const std::optional<std::string>& dtype, bool requires_grad) {
  const py::array array = py::array::ensure(data);
  if (!array) throw std::invalid_argument("maps.tensor: expected a numpy array or a nested list of numbers");
  if (array.dtype().kind() != 'f' && array.dtype().kind() != 'i' && array.dtype().kind() != 'u' &&
      array.dtype().kind() != 'b')
    throw std::invalid_argument("maps.tensor: expected numbers, got an array of dtype " +
                                std::string(py::str(array.dtype())));
  const bool is_float32 = array.dtype().is(py::dtype::of<float>());
  const ag::Dtype target = dtype ? parse_dtype(*dtype) : (is_float32 ? ag::Dtype::Float32 : ag::Dtype::Float64);
  ag::Tensor tensor = target == ag::Dtype::Float32 ? tensor_from_array<float>(array) : tensor_from_array<double>(array);
  if (requires_grad) tensor.requires_grad_(true);
  return tensor;
}

template <typename T>
py::array tensor_to_array(const ag::Tensor& tensor) {
  std::vector<py::ssize_t> shape(tensor.shape().begin(), tensor.shape().end());
  py::array_t<T> array(shape);
  if (tensor.numel() > 0)
    std::memcpy(array.mutable_data(), const_cast<ag::Tensor&>(tensor).data<T>(),
                sizeof(T) * static_cast<std::size_t>(tensor.numel()));
  return array;
}

py::array to_numpy(const ag::Tensor& tensor) {
  if (!tensor.defined()) throw std::invalid_argument("numpy(): the tensor is undefined");
  return tensor.dtype() == ag::Dtype::Float32 ? tensor_to_array<float>(tensor) : tensor_to_array<double>(tensor);
}

py::object optional_tensor(const ag::Tensor& tensor) { return tensor.defined() ? py::cast(tensor) : py::none(); }

std::vector<ag::Tensor> outputs_of(const py::object& result, const char* what) {
  if (py::isinstance<ag::Tensor>(result)) return {result.cast<ag::Tensor>()};
  if (py::isinstance<py::tuple>(result) || py::isinstance<py::list>(result))
    return result.cast<std::vector<ag::Tensor>>();
  throw std::invalid_argument(std::string(what) + ": the function must return a maps.Tensor or a tuple of them, not " +
                              std::string(py::str(py::type::of(result))));
}

ag::MultiFunction python_function(const py::function& fn, const char* what) {
  return [fn, what](const std::vector<ag::Tensor>& inputs) {
    py::tuple args(inputs.size());
    for (std::size_t i = 0; i < inputs.size(); ++i) args[i] = py::cast(inputs[i]);
    return outputs_of(fn(*args), what);
  };
}

std::vector<ag::Tensor> as_tensor_list(const py::object& tensors) {
  if (py::isinstance<ag::Tensor>(tensors)) return {tensors.cast<ag::Tensor>()};
  return tensors.cast<std::vector<ag::Tensor>>();
}

bool check_gradients(bool second_order, const py::function& fn, const py::object& inputs, double eps, double atol,
                     double rtol, bool raise_exception, unsigned seed) {
  const char* what = second_order ? "maps.gradgradcheck" : "maps.gradcheck";
  const ag::GradcheckOptions options{eps, atol, rtol};
  const std::vector<ag::Tensor> tensors = as_tensor_list(inputs);
  const std::string name = py::str(py::getattr(fn, "__name__", py::str("function")));
  const ag::GradcheckResult result = second_order
                                         ? ag::gradgradcheck(name, python_function(fn, what), tensors, options, seed)
                                         : ag::gradcheck(name, python_function(fn, what), tensors, options);
  if (!result.ok && raise_exception) throw std::runtime_error(std::string(what) + " failed: " + result.message);
  return result.ok;
}

}  // namespace

void bind_autograd(py::module_& m) {
  py::class_<ag::Tensor> tensor(m, "Tensor", "A tensor of the maps autograd engine (float32 or float64, row-major)");
  tensor
      .def(py::init([](const py::object& data, std::optional<std::string> dtype, bool requires_grad) {
             return tensor_from_python(data, dtype, requires_grad);
           }),
           py::arg("data"), py::arg("dtype") = py::none(), py::arg("requires_grad") = false)
      .def_property_readonly(
          "shape", [](const ag::Tensor& t) { return py::tuple(py::cast(std::vector<std::int64_t>(t.shape()))); })
      .def_property_readonly("dtype", [](const ag::Tensor& t) { return ag::to_string(t.dtype()); })
      .def_property_readonly("ndim", &ag::Tensor::dim)
      .def("numel", &ag::Tensor::numel)
      .def("numpy", &to_numpy, "A copy of the values as a numpy array of the tensor's dtype")
      .def(
          "__array__", [](const ag::Tensor& t, py::object) { return to_numpy(t); }, py::arg("dtype") = py::none())
      .def("item", &ag::Tensor::item)
      .def("__float__", &ag::Tensor::item)
      .def_property_readonly("requires_grad", &ag::Tensor::requires_grad)
      .def("requires_grad_", &ag::Tensor::requires_grad_, py::arg("requires_grad") = true,
           py::return_value_policy::reference_internal)
      .def_property_readonly("is_leaf", &ag::Tensor::is_leaf)
      .def_property_readonly(
          "grad", [](const ag::Tensor& t) { return optional_tensor(t.grad()); },
          "The gradient backward() accumulated into this leaf, or None")
      .def(
          "zero_grad", [](ag::Tensor& t) { t.set_grad(ag::Tensor()); }, "Forgets the accumulated gradient")
      .def(
          "backward",
          [](const ag::Tensor& t, std::optional<ag::Tensor> gradient, bool retain_graph, bool create_graph) {
            t.backward(gradient.value_or(ag::Tensor()), retain_graph, create_graph);
          },
          py::arg("gradient") = py::none(), py::arg("retain_graph") = false, py::arg("create_graph") = false)
      .def("detach", &ag::Tensor::detach)
      .def("clone", &ag::Tensor::clone)
      .def("to", [](const ag::Tensor& t, const std::string& dtype) { return t.to(parse_dtype(dtype)); })
      .def("reshape", [](const ag::Tensor& t, const std::vector<std::int64_t>& shape) { return t.reshape(shape); })
      .def("transpose", &ag::Tensor::transpose)
      .def_property_readonly("T", &ag::Tensor::t)
      .def("__repr__", &ag::Tensor::to_string)
      .def("__neg__", [](const ag::Tensor& a) { return -a; })
      .def("__matmul__", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::matmul(a, b); })
      .def("__pow__", [](const ag::Tensor& a, double b) { return ag::pow(a, b); })
      .def("__pow__", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::pow(a, b); })
      .def("__add__", [](const ag::Tensor& a, const ag::Tensor& b) { return a + b; })
      .def("__add__", [](const ag::Tensor& a, double b) { return a + b; })
      .def("__radd__", [](const ag::Tensor& a, double b) { return b + a; })
      .def("__sub__", [](const ag::Tensor& a, const ag::Tensor& b) { return a - b; })
      .def("__sub__", [](const ag::Tensor& a, double b) { return a - b; })
      .def("__rsub__", [](const ag::Tensor& a, double b) { return b - a; })
      .def("__mul__", [](const ag::Tensor& a, const ag::Tensor& b) { return a * b; })
      .def("__mul__", [](const ag::Tensor& a, double b) { return a * b; })
      .def("__rmul__", [](const ag::Tensor& a, double b) { return b * a; })
      .def("__truediv__", [](const ag::Tensor& a, const ag::Tensor& b) { return a / b; })
      .def("__truediv__", [](const ag::Tensor& a, double b) { return a / b; })
      .def("__rtruediv__", [](const ag::Tensor& a, double b) { return b / a; });

  m.def("exp", [](const ag::Tensor& x) { return ag::exp(x); });
  m.def("log", [](const ag::Tensor& x) { return ag::log(x); });
  m.def("sqrt", [](const ag::Tensor& x) { return ag::sqrt(x); });
  m.def("abs", [](const ag::Tensor& x) { return ag::abs(x); });
  m.def("tanh", [](const ag::Tensor& x) { return ag::tanh(x); });
  m.def("sigmoid", [](const ag::Tensor& x) { return ag::sigmoid(x); });
  m.def("relu", [](const ag::Tensor& x) { return ag::relu(x); });
  m.def("square", [](const ag::Tensor& x) { return ag::square(x); });
  m.def("clamp", [](const ag::Tensor& x, double lo, double hi) { return ag::clamp(x, lo, hi); });
  m.def("matmul", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::matmul(a, b); });
  m.def("maximum", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::maximum(a, b); });
  m.def("minimum", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::minimum(a, b); });
  m.def(
      "sum",
      [](const ag::Tensor& x, std::optional<std::vector<std::int64_t>> dims, bool keepdim) {
        return dims ? ag::sum(x, *dims, keepdim) : ag::sum(x);
      },
      py::arg("x"), py::arg("dims") = py::none(), py::arg("keepdim") = false);
  m.def(
      "mean",
      [](const ag::Tensor& x, std::optional<std::vector<std::int64_t>> dims, bool keepdim) {
        return dims ? ag::mean(x, *dims, keepdim) : ag::mean(x);
      },
      py::arg("x"), py::arg("dims") = py::none(), py::arg("keepdim") = false);
  m.def(
      "softmax", [](const ag::Tensor& x, std::int64_t dim) { return ag::softmax(x, dim); }, py::arg("x"),
      py::arg("dim"));
  m.def(
      "log_softmax", [](const ag::Tensor& x, std::int64_t dim) { return ag::log_softmax(x, dim); }, py::arg("x"),
      py::arg("dim"));
  m.def("mse_loss", [](const ag::Tensor& p, const ag::Tensor& t) { return ag::mse_loss(p, t); });
  m.def(
      "concat", [](const std::vector<ag::Tensor>& ts, std::int64_t dim) { return ag::concat(ts, dim); },
      py::arg("tensors"), py::arg("dim") = 0);
  m.def(
      "stack", [](const std::vector<ag::Tensor>& ts, std::int64_t dim) { return ag::stack(ts, dim); },
      py::arg("tensors"), py::arg("dim") = 0);

  m.def(
      "grad",
      [](const py::object& outputs, const py::object& inputs, const py::object& grad_outputs,
         std::optional<bool> retain_graph, bool create_graph, bool allow_unused) {
        const std::vector<ag::Tensor> gradients =
            ag::grad(as_tensor_list(outputs), as_tensor_list(inputs),
                     grad_outputs.is_none() ? std::vector<ag::Tensor>{} : as_tensor_list(grad_outputs), retain_graph,
                     create_graph, allow_unused);
        py::list result;
        for (const ag::Tensor& g : gradients) result.append(optional_tensor(g));
        return result;
      },
      py::arg("outputs"), py::arg("inputs"), py::arg("grad_outputs") = py::none(), py::arg("retain_graph") = py::none(),
      py::arg("create_graph") = false, py::arg("allow_unused") = false,
      "d(outputs)/d(inputs) as a list (None for an unused input with allow_unused), like torch.autograd.grad");
  m.def(
      "gradcheck",
      [](const py::function& fn, const py::object& inputs, double eps, double atol, double rtol, bool raise_exception) {
        return check_gradients(false, fn, inputs, eps, atol, rtol, raise_exception, 0);
      },
      py::arg("fn"), py::arg("inputs"), py::arg("eps") = 1e-6, py::arg("atol") = 1e-5, py::arg("rtol") = 1e-3,
      py::arg("raise_exception") = true,
      "Central differences against backward() for every float64 input that requires grad; fn(*inputs)");
  m.def(
      "gradgradcheck",
      [](const py::function& fn, const py::object& inputs, double eps, double atol, double rtol, bool raise_exception,
         unsigned seed) { return check_gradients(true, fn, inputs, eps, atol, rtol, raise_exception, seed); },
      py::arg("fn"), py::arg("inputs"), py::arg("eps") = 1e-6, py::arg("atol") = 1e-5, py::arg("rtol") = 1e-3,
      py::arg("raise_exception") = true, py::arg("seed") = 0u, "Second derivatives checked the same way");
  m.def("is_grad_enabled", &ag::GradMode::is_enabled);
  m.def("set_grad_enabled", &ag::GradMode::set_enabled, py::arg("enabled"));
  m.def("set_num_threads", &ag::set_num_threads, py::arg("threads"), "Threads the ops split their work over");
  m.def("num_threads", &ag::num_threads);
  m.def(
      "set_flush_denormal",
      [](bool on) {
        if (!ag::flush_denormal_supported()) return false;
        ag::set_flush_denormal(on);
        return true;
      },
      py::arg("mode"),
      "Flush denormal floats to zero on this thread (and the ops' threads) from now on, like "
      "torch.set_flush_denormal; returns whether the CPU supports it. maps train does it by default "
      "(train.flush_denormal).");
}

}  // namespace maps::python
