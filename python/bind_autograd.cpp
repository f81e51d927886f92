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

ag::Dtype parse_dtype(const std::string& name) {
  if (name == "float32") return ag::Dtype::Float32;
  if (name == "float64") return ag::Dtype::Float64;
  throw std::invalid_argument("dtype must be 'float32' or 'float64', not '" + name + "'");
}

namespace {

template <typename T>
ag::Tensor tensor_from_array(const py::array_t<T, py::array::c_style | py::array::forcecast>& array) {
  ag::Shape shape(array.shape(), array.shape() + array.ndim());
  ag::Tensor tensor = ag::empty(shape, ag::dtype_of<T>());
  if (tensor.numel() > 0)
    std::memcpy(tensor.data<T>(), array.data(), sizeof(T) * static_cast<std::size_t>(tensor.numel()));
  return tensor;
}

}  // namespace

// A numpy array (or anything numpy can make one of: lists, scalars) as a tensor; float32 input stays float32 unless
// a dtype says otherwise, everything else becomes float64 (the dtype of gradient checks). A maps.Tensor is copied
// (keeping its dtype unless told), cut from its graph.
ag::Tensor tensor_from_python(const py::object& data, const std::optional<std::string>& dtype, bool requires_grad) {
  if (py::isinstance<ag::Tensor>(data)) {
    const ag::Tensor& source = data.cast<const ag::Tensor&>();
    if (!source.defined()) throw std::invalid_argument("maps.tensor: the tensor is undefined");
    ag::Tensor tensor;
    {
      ag::NoGradGuard no_grad;  // a new leaf
      tensor = source.detach().to(dtype ? parse_dtype(*dtype) : source.dtype()).clone();
    }
    if (requires_grad) tensor.requires_grad_(true);
    return tensor;
  }
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

ag::Generator& default_generator() {
  static ag::Generator generator(0);
  return generator;
}

namespace {

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

// ----- indexing: t[key] as graph-recorded ops (narrow, index_select, reshape), so gradients flow back -----

// The rows `indices` (checked, non-negative) of dim `dim`, through index_select on dim 0.
ag::Tensor select_along(const ag::Tensor& x, std::int64_t dim, const std::vector<std::int64_t>& indices) {
  if (dim == 0) return ag::index_select(x, indices);
  return ag::transpose(ag::index_select(ag::transpose(x, 0, dim), indices), 0, dim);
}

py::index_error index_out_of_range(std::int64_t index, std::int64_t dim, std::int64_t size) {
  return py::index_error("index " + std::to_string(index) + " is out of range for dim " + std::to_string(dim) +
                         " of size " + std::to_string(size));
}

struct IndexItem {
  enum Kind { Int, Slice, Array, NewAxis, Ellipsis } kind;
  py::object value;
};

bool is_integer_scalar(const py::handle& item) {
  if (PyBool_Check(item.ptr())) return false;
  if (PyLong_Check(item.ptr())) return true;
  // numpy's integer scalars (np.int64(3)) and 0-d integer arrays.
  if (py::isinstance<py::array>(item)) {
    const py::array array = py::reinterpret_borrow<py::array>(item);
    return array.ndim() == 0 && (array.dtype().kind() == 'i' || array.dtype().kind() == 'u');
  }
  return PyIndex_Check(item.ptr()) && !py::isinstance<ag::Tensor>(item);
}

IndexItem classify(const py::handle& item) {
  if (item.is_none()) return {IndexItem::NewAxis, py::none()};
  if (item.ptr() == Py_Ellipsis) return {IndexItem::Ellipsis, py::none()};
  if (py::isinstance<py::slice>(item)) return {IndexItem::Slice, py::reinterpret_borrow<py::object>(item)};
  if (PyBool_Check(item.ptr()))
    throw py::type_error("maps.Tensor: a bool is not an index (use a list or numpy array of bools as a mask)");
  if (is_integer_scalar(item)) return {IndexItem::Int, py::reinterpret_borrow<py::object>(item)};
  if (py::isinstance<ag::Tensor>(item))
    throw py::type_error(
        "maps.Tensor: a maps.Tensor holds floats and is not an index; index with ints, slices, lists or numpy "
        "integer or bool arrays");
  if (py::isinstance<py::list>(item) || py::isinstance<py::tuple>(item) || py::isinstance<py::array>(item))
    return {IndexItem::Array, py::reinterpret_borrow<py::object>(item)};
  throw py::type_error("maps.Tensor: cannot index with an object of type " +
                       std::string(py::str(py::type::of(item).attr("__name__"))) +
                       "; index with ints, slices, None, ..., lists or numpy integer or bool arrays");
}

// A list or array index as checked, non-negative positions along a dim of `size`: integers (negative ones count
// from the end) or a bool mask of the dim's length.
std::vector<std::int64_t> index_positions(const py::object& item, std::int64_t dim, std::int64_t size) {
  const py::array array = py::array::ensure(item);
  if (!array) throw py::type_error("maps.Tensor: an index list must hold integers or bools");
  if (array.ndim() != 1)
    throw py::index_error("maps.Tensor: index arrays must be 1-d, got one of " + std::to_string(array.ndim()) +
                          " dims");
  const char kind = array.dtype().kind();
  std::vector<std::int64_t> positions;
  if (kind == 'b') {
    if (array.shape(0) != size)
      throw py::index_error("maps.Tensor: a bool mask of length " + std::to_string(array.shape(0)) + " for dim " +
                            std::to_string(dim) + " of size " + std::to_string(size));
    const auto mask = py::array_t<bool, py::array::c_style | py::array::forcecast>::ensure(array);
    for (std::int64_t i = 0; i < size; ++i)
      if (mask.data()[i]) positions.push_back(i);
    return positions;
  }
  if (kind != 'i' && kind != 'u' && !(array.size() == 0))  // [] is an empty index, as numpy reads it
    throw py::type_error("maps.Tensor: index arrays must hold integers or bools, not " +
                         std::string(py::str(array.dtype())));
  const auto values = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(array);
  for (py::ssize_t k = 0; k < values.size(); ++k) {
    const std::int64_t index = values.data()[k];
    if (index < -size || index >= size) throw index_out_of_range(index, dim, size);
    positions.push_back(index < 0 ? index + size : index);
  }
  return positions;
}

// x[key] as numpy reads it, for keys of ints, slices (any step), None, one ellipsis and at most one list or 1-d
// integer / bool array (numpy would pair several up).
ag::Tensor index_tensor(const ag::Tensor& x, const py::object& key) {
  if (!x.defined()) throw std::invalid_argument("maps.Tensor: the tensor is undefined");
  std::vector<IndexItem> items;
  if (py::isinstance<py::tuple>(key)) {
    for (const py::handle& item : py::reinterpret_borrow<py::tuple>(key)) items.push_back(classify(item));
  } else {
    items.push_back(classify(key));
  }
  const std::int64_t rank = x.dim();
  std::int64_t consumed = 0, ellipses = 0, arrays = 0;
  for (const IndexItem& item : items) {
    if (item.kind == IndexItem::Int || item.kind == IndexItem::Slice || item.kind == IndexItem::Array) ++consumed;
    if (item.kind == IndexItem::Ellipsis) ++ellipses;
    if (item.kind == IndexItem::Array) ++arrays;
  }
  if (ellipses > 1) throw py::index_error("maps.Tensor: an index can hold only one ellipsis (...)");
  if (arrays > 1)
    throw py::index_error(
        "maps.Tensor: one list or array per index (numpy would pair several up, which maps.Tensor does not; "
        "index one dim at a time)");
  if (consumed > rank)
    throw py::index_error("maps.Tensor: too many indices for a tensor of " + std::to_string(rank) +
                          " dims: " + std::to_string(consumed) + " given (shape " + ag::to_string(x.shape()) + ")");

  ag::Tensor y = x;
  std::int64_t dim = 0;         // the dim of y the next item indexes
  std::int64_t source_dim = 0;  // the same dim counted in x, for messages
  for (const IndexItem& item : items) {
    switch (item.kind) {
      case IndexItem::NewAxis: {
        ag::Shape shape = y.shape();
        shape.insert(shape.begin() + dim, 1);
        y = ag::reshape(y, shape);
        ++dim;
        break;
      }
      case IndexItem::Ellipsis:
        dim += rank - consumed;
        source_dim += rank - consumed;
        break;
      case IndexItem::Int: {
        const std::int64_t size = y.size(dim);
        const std::int64_t index = py::int_(item.value).cast<std::int64_t>();
        if (index < -size || index >= size) throw index_out_of_range(index, source_dim, size);
        ag::Shape shape = y.shape();
        shape.erase(shape.begin() + dim);
        y = ag::reshape(ag::narrow(y, dim, index < 0 ? index + size : index, 1), shape);
        ++source_dim;
        break;
      }
      case IndexItem::Slice: {
        py::ssize_t start = 0, stop = 0, step = 0, length = 0;
        if (!py::reinterpret_borrow<py::slice>(item.value).compute(y.size(dim), &start, &stop, &step, &length))
          throw py::error_already_set();
        if (step == 1) {
          y = ag::narrow(y, dim, start, length);
        } else {
          std::vector<std::int64_t> positions;
          for (py::ssize_t k = 0; k < length; ++k) positions.push_back(start + k * step);
          y = select_along(y, dim, positions);
        }
        ++dim;
        ++source_dim;
        break;
      }
      case IndexItem::Array:
        y = select_along(y, dim, index_positions(item.value, source_dim, y.size(dim)));
        ++dim;
        ++source_dim;
        break;
    }
  }
  return y;
}

// reshape's arguments as PyTorch takes them: t.reshape(2, 3) or t.reshape((2, 3)).
ag::Shape shape_argument(const py::args& args) {
  if (args.size() == 1 && !is_integer_scalar(args[0])) return args[0].cast<ag::Shape>();
  return args.cast<ag::Shape>();
}

ag::Tensor squeeze(const ag::Tensor& x, std::optional<std::int64_t> dim) {
  ag::Shape shape;
  if (dim) {
    const std::int64_t d = *dim < 0 ? *dim + x.dim() : *dim;
    if (d < 0 || d >= x.dim())
      throw py::index_error("squeeze: dim " + std::to_string(*dim) + " of a tensor of " + std::to_string(x.dim()) +
                            " dims");
    shape = x.shape();
    if (shape[d] == 1) shape.erase(shape.begin() + d);
  } else {
    for (std::int64_t s : x.shape())
      if (s != 1) shape.push_back(s);
  }
  return ag::reshape(x, shape);
}

ag::Tensor unsqueeze(const ag::Tensor& x, std::int64_t dim) {
  const std::int64_t d = dim < 0 ? dim + x.dim() + 1 : dim;
  if (d < 0 || d > x.dim())
    throw py::index_error("unsqueeze: dim " + std::to_string(dim) + " of a tensor of " + std::to_string(x.dim()) +
                          " dims");
  ag::Shape shape = x.shape();
  shape.insert(shape.begin() + d, 1);
  return ag::reshape(x, shape);
}

// A dims argument: None, one int or a list of ints.
std::optional<std::vector<std::int64_t>> dims_argument(const py::object& dims) {
  if (dims.is_none()) return std::nullopt;
  if (is_integer_scalar(dims)) return std::vector<std::int64_t>{dims.cast<std::int64_t>()};
  return dims.cast<std::vector<std::int64_t>>();
}

ag::Tensor sum(const ag::Tensor& x, const py::object& dims, bool keepdim) {
  const auto d = dims_argument(dims);
  return d ? ag::sum(x, *d, keepdim) : ag::sum(x);
}
ag::Tensor mean(const ag::Tensor& x, const py::object& dims, bool keepdim) {
  const auto d = dims_argument(dims);
  return d ? ag::mean(x, *d, keepdim) : ag::mean(x);
}
ag::Tensor amax(const ag::Tensor& x, const py::object& dims, bool keepdim) {
  const auto d = dims_argument(dims);
  return d ? ag::amax(x, *d, keepdim) : ag::amax(x);
}

ag::Tensor clamp_optional(const ag::Tensor& x, std::optional<double> min, std::optional<double> max) {
  if (min && max) return ag::clamp(x, *min, *max);
  if (min) return ag::clamp_min(x, *min);
  if (max) return ag::clamp_max(x, *max);
  throw std::invalid_argument("clamp: give min, max or both");
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
      .def(
          "reshape", [](const ag::Tensor& t, const py::args& shape) { return t.reshape(shape_argument(shape)); },
          "t.reshape(2, 3) or t.reshape((2, 3)); one dim may be -1")
      .def("view", [](const ag::Tensor& t, const py::args& shape) { return t.reshape(shape_argument(shape)); })
      .def("flatten", [](const ag::Tensor& t) { return t.reshape({-1}); })
      .def("squeeze", &squeeze, py::arg("dim") = py::none(), "Drops dims of size 1 (only `dim`, when given)")
      .def("unsqueeze", &unsqueeze, py::arg("dim"))
      .def("transpose", &ag::Tensor::transpose)
      .def(
          "size",
          [](const ag::Tensor& t, std::optional<std::int64_t> dim) -> py::object {
            if (!dim) return py::tuple(py::cast(std::vector<std::int64_t>(t.shape())));
            if (*dim < -t.dim() || *dim >= t.dim())
              throw py::index_error("size: dim " + std::to_string(*dim) + " of a tensor of " + std::to_string(t.dim()) +
                                    " dims");
            return py::int_(t.size(*dim));
          },
          py::arg("dim") = py::none())
      .def("dim", &ag::Tensor::dim)
      .def("__len__",
           [](const ag::Tensor& t) {
             if (t.dim() == 0) throw py::type_error("len() of a 0-d tensor");
             return t.size(0);
           })
      .def("__getitem__", &index_tensor,
           "numpy's basic indexing and one list / integer or bool array, as graph-recorded ops (gradients flow "
           "back); an index out of range is an IndexError naming it, the dim and its size")
      .def("sum", &sum, py::arg("dims") = py::none(), py::arg("keepdim") = false)
      .def("mean", &mean, py::arg("dims") = py::none(), py::arg("keepdim") = false)
      .def("amax", &amax, py::arg("dims") = py::none(), py::arg("keepdim") = false)
      .def("exp", [](const ag::Tensor& x) { return ag::exp(x); })
      .def("log", [](const ag::Tensor& x) { return ag::log(x); })
      .def("sqrt", [](const ag::Tensor& x) { return ag::sqrt(x); })
      .def("abs", [](const ag::Tensor& x) { return ag::abs(x); })
      .def("tanh", [](const ag::Tensor& x) { return ag::tanh(x); })
      .def("sigmoid", [](const ag::Tensor& x) { return ag::sigmoid(x); })
      .def("relu", [](const ag::Tensor& x) { return ag::relu(x); })
      .def("square", [](const ag::Tensor& x) { return ag::square(x); })
      .def(
          "clamp",
          [](const ag::Tensor& x, std::optional<double> lo, std::optional<double> hi) {
            return clamp_optional(x, lo, hi);
          },
          py::arg("min") = py::none(), py::arg("max") = py::none())
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
  m.def("clamp", &clamp_optional, py::arg("x"), py::arg("min") = py::none(), py::arg("max") = py::none());
  m.def(
      "softplus", [](const ag::Tensor& x) { return ag::softplus(x); }, "log(1 + exp(x)), computed stably");
  m.def("erf", [](const ag::Tensor& x) { return ag::erf(x); });
  m.def("neg", [](const ag::Tensor& x) { return ag::neg(x); });
  m.def("pow", [](const ag::Tensor& x, double e) { return ag::pow(x, e); });
  m.def("pow", [](const ag::Tensor& x, const ag::Tensor& e) { return ag::pow(x, e); });
  m.def("add", [](const ag::Tensor& a, const ag::Tensor& b) { return a + b; });
  m.def("add", [](const ag::Tensor& a, double b) { return a + b; });
  m.def("sub", [](const ag::Tensor& a, const ag::Tensor& b) { return a - b; });
  m.def("sub", [](const ag::Tensor& a, double b) { return a - b; });
  m.def("mul", [](const ag::Tensor& a, const ag::Tensor& b) { return a * b; });
  m.def("mul", [](const ag::Tensor& a, double b) { return a * b; });
  m.def("div", [](const ag::Tensor& a, const ag::Tensor& b) { return a / b; });
  m.def("div", [](const ag::Tensor& a, double b) { return a / b; });
  m.def(
      "where", [](const ag::Tensor& c, const ag::Tensor& a, const ag::Tensor& b) { return ag::where(c, a, b); },
      py::arg("condition"), py::arg("a"), py::arg("b"), "condition ? a : b elementwise (condition: nonzero is true)");
  m.def(
      "gt", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::gt(a, b); }, "1 where a > b (no gradient)");
  m.def(
      "eq", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::eq(a, b); }, "1 where a == b (no gradient)");
  m.def(
      "reshape", [](const ag::Tensor& x, const ag::Shape& shape) { return ag::reshape(x, shape); }, py::arg("x"),
      py::arg("shape"));
  m.def(
      "transpose", [](const ag::Tensor& x, std::int64_t d0, std::int64_t d1) { return ag::transpose(x, d0, d1); },
      py::arg("x"), py::arg("dim0"), py::arg("dim1"));
  m.def(
      "expand", [](const ag::Tensor& x, const ag::Shape& shape) { return ag::expand(x, shape); }, py::arg("x"),
      py::arg("shape"), "Broadcast to shape (a copy)");
  m.def(
      "narrow",
      [](const ag::Tensor& x, std::int64_t dim, std::int64_t start, std::int64_t length) {
        return ag::narrow(x, dim, start, length);
      },
      py::arg("x"), py::arg("dim"), py::arg("start"), py::arg("length"));
  m.def(
      "index_select",
      [](const ag::Tensor& x, std::int64_t dim, const std::vector<std::int64_t>& indices) {
        if (dim < -x.dim() || dim >= x.dim())
          throw py::index_error("index_select: dim " + std::to_string(dim) + " of a tensor of " +
                                std::to_string(x.dim()) + " dims");
        const std::int64_t d = dim < 0 ? dim + x.dim() : dim;
        for (std::int64_t i : indices)
          if (i < 0 || i >= x.size(d)) throw index_out_of_range(i, d, x.size(d));
        return select_along(x, d, indices);
      },
      py::arg("x"), py::arg("dim"), py::arg("indices"), "torch.index_select: the entries `indices` of dim `dim`");
  m.def(
      "linear",
      [](const ag::Tensor& x, const ag::Tensor& weight, std::optional<ag::Tensor> bias) {
        return ag::linear(x, weight, bias.value_or(ag::Tensor()));
      },
      py::arg("x"), py::arg("weight"), py::arg("bias") = py::none(),
      "x @ weight^T + bias, like torch.nn.functional.linear: x [..., in] (2-d or 3-d), weight [out, in]");
  m.def(
      "one_hot",
      [](const std::vector<std::int64_t>& indices, std::int64_t classes, const std::string& dtype) {
        return ag::one_hot(indices, classes, parse_dtype(dtype));
      },
      py::arg("indices"), py::arg("classes"), py::arg("dtype") = "float32");
  m.def("matmul", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::matmul(a, b); });
  m.def("maximum", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::maximum(a, b); });
  m.def("minimum", [](const ag::Tensor& a, const ag::Tensor& b) { return ag::minimum(a, b); });
  m.def("sum", &sum, py::arg("x"), py::arg("dims") = py::none(), py::arg("keepdim") = false);
  m.def("mean", &mean, py::arg("x"), py::arg("dims") = py::none(), py::arg("keepdim") = false);
  m.def("amax", &amax, py::arg("x"), py::arg("dims") = py::none(), py::arg("keepdim") = false,
        "The largest value (over `dims`); ties share the gradient");
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

  // Random numbers and factories.
  py::class_<ag::Generator>(m, "Generator", "A seeded source of random numbers (like torch.Generator)")
      .def(py::init<std::uint64_t>(), py::arg("seed") = 0)
      .def(
          "manual_seed",
          [](ag::Generator& g, std::uint64_t seed) -> ag::Generator& {
            g.seed(seed);
            return g;
          },
          py::arg("seed"), py::return_value_policy::reference_internal);
  m.def(
      "manual_seed", [](std::uint64_t seed) { default_generator().seed(seed); }, py::arg("seed"),
      "Seeds the generator that layers and random factories use when given none (like torch.manual_seed)");
  auto factory = [&m](const char* name, double value) {
    m.def(
        name,
        [value](const ag::Shape& shape, const std::string& dtype, bool requires_grad) {
          ag::Tensor t = ag::full(shape, value, parse_dtype(dtype));
          if (requires_grad) t.requires_grad_(true);
          return t;
        },
        py::arg("shape"), py::arg("dtype") = "float32", py::arg("requires_grad") = false);
  };
  factory("zeros", 0.0);
  factory("ones", 1.0);
  m.def(
      "full",
      [](const ag::Shape& shape, double value, const std::string& dtype, bool requires_grad) {
        ag::Tensor t = ag::full(shape, value, parse_dtype(dtype));
        if (requires_grad) t.requires_grad_(true);
        return t;
      },
      py::arg("shape"), py::arg("value"), py::arg("dtype") = "float32", py::arg("requires_grad") = false);
  m.def(
      "arange",
      [](double start, std::optional<double> end, double step, const std::string& dtype) {
        return end ? ag::arange(start, *end, step, parse_dtype(dtype))
                   : ag::arange(0.0, start, step, parse_dtype(dtype));
      },
      py::arg("start"), py::arg("end") = py::none(), py::arg("step") = 1.0, py::arg("dtype") = "float32",
      "arange(end) or arange(start, end, step), like torch.arange");
  m.def(
      "rand",
      [](const ag::Shape& shape, const std::string& dtype, ag::Generator* generator, bool requires_grad) {
        ag::Tensor t = ag::rand(shape, generator_or_default(generator), parse_dtype(dtype));
        if (requires_grad) t.requires_grad_(true);
        return t;
      },
      py::arg("shape"), py::arg("dtype") = "float32", py::arg("generator") = nullptr, py::arg("requires_grad") = false,
      "Uniform in [0, 1)");
  m.def(
      "randn",
      [](const ag::Shape& shape, const std::string& dtype, ag::Generator* generator, bool requires_grad) {
        ag::Tensor t = ag::randn(shape, generator_or_default(generator), parse_dtype(dtype));
        if (requires_grad) t.requires_grad_(true);
        return t;
      },
      py::arg("shape"), py::arg("dtype") = "float32", py::arg("generator") = nullptr, py::arg("requires_grad") = false,
      "Standard normal");
}

}  // namespace maps::python
