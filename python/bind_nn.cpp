#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "nn/nn.h"
#include "python/bindings.h"

namespace py = pybind11;

namespace maps::python {
// Named, so that the helpers of the bind_*.cpp files cannot collide in a unity build.
namespace nn_bindings {
namespace {

// maps.nn.Module subclassed in Python (the trampoline of every Python-defined module). It is a UnaryModule, so that
// Sequential (and any C++ caller of forward(x)) can call the Python forward; register_* are public here for the
// Python side; clone() is refused, since C++ cannot copy the Python half of the object.
class PythonModule : public nn::UnaryModule {
 public:
  explicit PythonModule(std::string type_name) : nn::UnaryModule(std::move(type_name)) {}

  using nn::Module::register_buffer;
  using nn::Module::register_module;
  using nn::Module::register_parameter;
  using nn::Module::set_buffer;

  // The Python forward, for C++ callers (Sequential). The lookup is by nn::Module, the type pybind11 knows the
  // Python instance by.
  ag::Tensor forward(const ag::Tensor& x) override {
    py::gil_scoped_acquire gil;
    const py::function override = py::get_override(static_cast<const nn::Module*>(this), "forward");
    if (!override) throw py::type_error(type_name() + " defines no forward");
    const py::object result = override(x);
    if (!py::isinstance<ag::Tensor>(result))
      throw py::type_error(type_name() + ".forward returned a " +
                           std::string(py::str(py::type::of(result).attr("__name__"))) +
                           ", not the one maps.Tensor a caller of forward(x) needs");
    return result.cast<ag::Tensor>();
  }

 protected:
  std::shared_ptr<nn::Module> shallow_copy() const override {
    py::gil_scoped_acquire gil;
    PyErr_SetString(
        PyExc_NotImplementedError,
        (type_name() + ".clone(): a module defined in Python cannot be cloned (C++ cannot copy its Python part); build "
                       "a new one and load_state_dict(module.state_dict()) into it")
            .c_str());
    throw py::error_already_set();
  }
};

PythonModule& python_module(nn::Module& module, const char* what) {
  auto* python = dynamic_cast<PythonModule*>(&module);
  if (python == nullptr)
    throw py::type_error(module.type_name() + "." + what +
                         "(): only a module defined in Python (a maps.nn.Module subclass) registers; the slots of " +
                         module.type_name() + ", a C++ module, are fixed");
  return *python;
}

std::string path_of(const py::object& path) { return py::str(py::module_::import("os").attr("fspath")(path)); }

// A checkpoint that is not there is a FileNotFoundError naming it (the reader's own errors name it too).
void check_exists(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) {
    PyErr_SetString(PyExc_FileNotFoundError, ("checkpoint " + path + ": no such file").c_str());
    throw py::error_already_set();
  }
}

py::list named_list(const nn::NamedTensors& tensors) {
  py::list out;
  for (const nn::NamedTensor& t : tensors) out.append(py::make_tuple(t.name, t.tensor));
  return out;
}

py::list tensor_list(const nn::NamedTensors& tensors) {
  py::list out;
  for (const nn::NamedTensor& t : tensors) out.append(py::cast(t.tensor));
  return out;
}

py::dict named_dict(const nn::NamedTensors& tensors) {
  py::dict out;
  for (const nn::NamedTensor& t : tensors) out[py::str(t.name)] = py::cast(t.tensor);
  return out;
}

// A state as a dict or a sequence of (name, tensor) pairs; values are maps.Tensors or anything maps.tensor takes.
nn::NamedTensors named_tensors(const py::object& state, const char* what) {
  nn::NamedTensors out;
  auto add = [&](const py::handle& name, const py::handle& value) {
    if (!py::isinstance<py::str>(name))
      throw py::type_error(std::string(what) + ": names must be strings, not " +
                           std::string(py::str(py::type::of(name).attr("__name__"))));
    const auto object = py::reinterpret_borrow<py::object>(value);
    out.push_back({name.cast<std::string>(), py::isinstance<ag::Tensor>(object)
                                                 ? object.cast<ag::Tensor>()
                                                 : tensor_from_python(object, std::nullopt, false)});
  };
  if (py::isinstance<py::dict>(state)) {
    for (const auto& [name, value] : py::reinterpret_borrow<py::dict>(state)) add(name, value);
    return out;
  }
  if (py::isinstance<py::str>(state) || !py::hasattr(state, "__iter__"))
    throw py::type_error(std::string(what) + ": expected a dict or a list of (name, tensor) pairs");
  for (const py::handle& entry : state) {
    const auto pair = py::reinterpret_borrow<py::object>(entry);
    if (!py::isinstance<py::sequence>(pair) || py::len(pair) != 2)
      throw py::type_error(std::string(what) + ": expected a dict or a list of (name, tensor) pairs");
    add(pair[py::int_(0)], pair[py::int_(1)]);
  }
  return out;
}

// The tensors an optimiser updates: a module's parameters or an iterable of tensors (one parameter group).
std::vector<ag::Tensor> optimiser_parameters(const py::object& params, const char* what) {
  if (py::isinstance<nn::Module>(params)) return params.cast<nn::Module&>().parameters();
  if (py::isinstance<ag::Tensor>(params) || !py::hasattr(params, "__iter__"))
    throw py::type_error(std::string(what) + ": params must be an iterable of maps.Tensors or a maps.nn.Module");
  std::vector<ag::Tensor> out;
  for (const py::handle& p : params) {
    if (py::isinstance<py::dict>(p))
      throw py::type_error(std::string(what) +
                           ": parameter groups (dicts) are not supported: one group of tensors (Adam.set_lr_scale "
                           "gives a parameter its own learning rate)");
    if (!py::isinstance<ag::Tensor>(p))
      throw py::type_error(std::string(what) + ": parameter " + std::to_string(out.size()) + " is a " +
                           std::string(py::str(py::type::of(p).attr("__name__"))) + ", not a maps.Tensor");
    out.push_back(p.cast<ag::Tensor>());
  }
  return out;
}

// Every descendant (this module first, as ""), with dotted names, like torch's named_modules().
void collect_modules(const std::shared_ptr<nn::Module>& module, const std::string& prefix, py::list& out) {
  out.append(py::make_tuple(prefix, module));
  for (const nn::NamedModule& child : module->named_children())
    collect_modules(child.module, prefix.empty() ? child.name : prefix + "." + child.name, out);
}

// The parameter, buffer or child named `name` (no dots) of this module, for attribute access from Python.
py::object slot(const nn::Module& module, const std::string& name) {
  for (const nn::NamedTensor& p : module.named_parameters(false))
    if (p.name == name) return py::cast(p.tensor);
  for (const nn::NamedTensor& b : module.named_buffers(false))
    if (b.name == name) return py::cast(b.tensor);
  for (const nn::NamedModule& c : module.named_children())
    if (c.name == name) return py::cast(c.module);
  throw py::attribute_error("'" + module.type_name() + "' object has no attribute '" + name + "'");
}

template <typename M>
std::shared_ptr<M> converted(std::shared_ptr<M> module, const std::string& dtype) {
  const ag::Dtype target = parse_dtype(dtype);
  if (target != ag::Dtype::Float32) module->to(target);
  return module;
}

// A module a container keeps, given from Python, as the unary module the container calls.
std::shared_ptr<nn::UnaryModule> unary_module(const py::object& object, const std::string& where) {
  if (!py::isinstance<nn::Module>(object))
    throw py::type_error(where + ": expected a maps.nn.Module, got a " +
                         std::string(py::str(py::type::of(object).attr("__name__"))));
  auto module = std::dynamic_pointer_cast<nn::UnaryModule>(keep_python_alive<nn::Module>(object));
  if (!module)
    throw py::type_error(where + ": " + object.cast<nn::Module&>().type_name() +
                         " is not a module of one input and one output");
  return module;
}

std::shared_ptr<nn::Module> child_of(const nn::Module& module, std::size_t i, const char* what) {
  const auto& children = module.named_children();
  if (i >= children.size())
    throw py::index_error(std::string(what) + ": index " + std::to_string(i) + " is out of range for " +
                          std::to_string(children.size()) + " modules");
  return children[i].module;
}

std::size_t container_index(std::int64_t i, std::size_t size, const char* what) {
  const auto n = static_cast<std::int64_t>(size);
  if (i < -n || i >= n)
    throw py::index_error(std::string(what) + ": index " + std::to_string(i) + " is out of range for " +
                          std::to_string(n) + " modules");
  return static_cast<std::size_t>(i < 0 ? i + n : i);
}

void bind_module(py::module_& nn_m) {
  py::class_<nn::Module, PythonModule, std::shared_ptr<nn::Module>> module(
      nn_m, "Module",
      "Base of every layer, after torch.nn.Module. Subclass it in Python: call super().__init__(), assign "
      "maps.nn.Parameter and maps.nn.Module attributes (or register_parameter / register_module) and define "
      "forward; the parameters then appear in named_parameters(), state_dict() and optimisers.");
  module.def(py::init_alias<std::string>(), py::arg("type_name") = "Module")
      .def_property_readonly("type_name", &nn::Module::type_name, "The class name used in error messages")
      .def(
          "named_parameters", [](const nn::Module& m, bool recurse) { return named_list(m.named_parameters(recurse)); },
          py::arg("recurse") = true,
          "[(dotted name, Tensor)], own parameters first, then each child's; the tensors are the module's own")
      .def(
          "parameters", [](const nn::Module& m, bool recurse) { return tensor_list(m.named_parameters(recurse)); },
          py::arg("recurse") = true)
      .def(
          "named_buffers", [](const nn::Module& m, bool recurse) { return named_list(m.named_buffers(recurse)); },
          py::arg("recurse") = true)
      .def(
          "buffers", [](const nn::Module& m, bool recurse) { return tensor_list(m.named_buffers(recurse)); },
          py::arg("recurse") = true)
      .def("named_children",
           [](const nn::Module& m) {
             py::list out;
             for (const nn::NamedModule& c : m.named_children()) out.append(py::make_tuple(c.name, c.module));
             return out;
           })
      .def("children", &nn::Module::children)
      .def("named_modules",
           [](const std::shared_ptr<nn::Module>& m) {
             py::list out;
             collect_modules(m, "", out);
             return out;
           })
      .def("parameter", &nn::Module::parameter, py::arg("name"), "The parameter at a dotted name")
      .def("parameter_count", &nn::Module::parameter_count, "The number of scalars in every parameter")
      .def(
          "state_dict", [](const nn::Module& m) { return named_dict(m.state_dict()); },
          "{dotted name: Tensor}: parameters then buffers, detached, sharing storage with the module")
      .def(
          "load_state_dict",
          [](nn::Module& m, const py::object& state) { m.load_state_dict(named_tensors(state, "load_state_dict")); },
          py::arg("state"),
          "Copies the values in; every name, shape and dtype must match (a ValueError lists every missing, "
          "unexpected and mismatched name)")
      .def(
          "train",
          [](const py::object& self, bool mode) {
            self.cast<nn::Module&>().train(mode);
            return self;
          },
          py::arg("mode") = true)
      .def("eval",
           [](const py::object& self) {
             self.cast<nn::Module&>().eval();
             return self;
           })
      .def_property_readonly("training", &nn::Module::is_training)
      .def("zero_grad", &nn::Module::zero_grad, "Every parameter's grad to None")
      .def(
          "requires_grad_",
          [](const py::object& self, bool on) {
            for (ag::Tensor& p : self.cast<nn::Module&>().parameters()) p.requires_grad_(on);
            return self;
          },
          py::arg("requires_grad") = true)
      .def(
          "to",
          [](const py::object& self, const std::string& dtype) {
            self.cast<nn::Module&>().to(parse_dtype(dtype));
            return self;
          },
          py::arg("dtype"),
          "Converts every parameter and buffer to 'float32' or 'float64' (new tensors: build optimisers after)")
      .def("clone", &nn::Module::clone,
           "A deep copy (new parameters with copies of the values); refused for a module defined in Python")
      .def("replace_parameter", &nn::Module::replace_parameter, py::arg("name"), py::arg("tensor"),
           "Puts `tensor` (same shape and dtype; any tensor, e.g. w - lr * g) in the parameter slot at a dotted "
           "name, so the next forward uses it")
      .def(
          "register_parameter",
          [](nn::Module& m, const std::string& name, ag::Tensor tensor, bool requires_grad) {
            PythonModule& self = python_module(m, "register_parameter");
            const std::size_t slot = self.register_parameter(name, std::move(tensor), requires_grad);
            return self.named_parameters(false)[slot].tensor;
          },
          py::arg("name"), py::arg("tensor"), py::arg("requires_grad") = true,
          "Registers a leaf tensor as a parameter and returns it (the same tensor, now requiring grad)")
      .def(
          "register_buffer",
          [](nn::Module& m, const std::string& name, const ag::Tensor& tensor) {
            PythonModule& self = python_module(m, "register_buffer");
            const std::size_t slot = self.register_buffer(name, tensor);
            return self.named_buffers(false)[slot].tensor;
          },
          py::arg("name"), py::arg("tensor"), "A tensor saved with the state but never trained")
      .def(
          "register_module",
          [](nn::Module& m, const std::string& name, const py::object& child) {
            PythonModule& self = python_module(m, "register_module");
            if (!py::isinstance<nn::Module>(child))
              throw py::type_error(self.type_name() + ".register_module(\"" + name + "\"): expected a maps.nn.Module");
            self.register_module(name, keep_python_alive<nn::Module>(child));
            return child;
          },
          py::arg("name"), py::arg("module"), "Registers a child module (kept alive while this module holds it)")
      .def(
          "_set_buffer",
          [](nn::Module& m, const std::string& name, const ag::Tensor& tensor) {
            PythonModule& self = python_module(m, "register_buffer");
            const nn::NamedTensors buffers = self.named_buffers(false);
            for (std::size_t i = 0; i < buffers.size(); ++i)
              if (buffers[i].name == name) return self.set_buffer(i, tensor);
            throw py::attribute_error(self.type_name() + " has no buffer \"" + name + "\"");
          },
          py::arg("name"), py::arg("tensor"))
      .def("_slot", &slot, py::arg("name"))
      .def(
          "save",
          [](const nn::Module& m, const py::object& path, const std::string& config) {
            nn::save(m, path_of(path), config);
          },
          py::arg("path"), py::arg("config") = "",
          "state_dict() (and a free-form config string) to a checkpoint file, the format of maps train's")
      .def(
          "load",
          [](nn::Module& m, const py::object& path) {
            const std::string file = path_of(path);
            check_exists(file);
            return nn::load(m, file);
          },
          py::arg("path"),
          "Loads a checkpoint file into the module (unchanged when anything is wrong) and returns its config")
      .def("extra_repr", [](const nn::Module&) { return std::string(); })
      .def("__call__", [](const py::object& self, const py::args& args, const py::kwargs& kwargs) {
        return self.attr("forward")(*args, **kwargs);
      });
  nn_m.def(
      "_is_constructed",
      [](const py::object& object) {
        if (!py::isinstance<nn::Module>(object)) return false;
        for (const auto& v_h : py::detail::values_and_holders(reinterpret_cast<py::detail::instance*>(object.ptr())))
          if (!v_h.holder_constructed()) return false;
        return true;
      },
      "Whether a maps.nn.Module's C++ part exists (its __init__ ran)");

  py::class_<nn::UnaryModule, nn::Module, std::shared_ptr<nn::UnaryModule>>(
      nn_m, "UnaryModule", "A module of one input and one output (what Sequential chains)")
      .def("forward", &nn::UnaryModule::forward, py::arg("x"));
}

void bind_layers(py::module_& nn_m) {
  py::class_<nn::Linear, nn::UnaryModule, std::shared_ptr<nn::Linear>>(
      nn_m, "Linear",
      "y = x W^T + b, as torch.nn.Linear: weight [out, in], bias [out], both U(-1/sqrt(in), 1/sqrt(in)); input "
      "[batch, in] or [b, n, in]")
      .def(py::init([](std::int64_t in_features, std::int64_t out_features, bool bias, const std::string& dtype,
                       ag::Generator* generator) {
             return converted(
                 std::make_shared<nn::Linear>(in_features, out_features, generator_or_default(generator), bias), dtype);
           }),
           py::arg("in_features"), py::arg("out_features"), py::arg("bias") = true, py::arg("dtype") = "float32",
           py::arg("generator") = nullptr)
      .def_property_readonly("in_features", &nn::Linear::in_features)
      .def_property_readonly("out_features", &nn::Linear::out_features)
      .def_property_readonly("weight", &nn::Linear::weight)
      .def_property_readonly("bias", [](const nn::Linear& l) { return l.has_bias() ? py::cast(l.bias()) : py::none(); })
      .def(
          "reset_parameters", [](nn::Linear& l, ag::Generator* g) { l.reset_parameters(generator_or_default(g)); },
          py::arg("generator") = nullptr)
      .def("extra_repr", [](const nn::Linear& l) {
        return "in_features=" + std::to_string(l.in_features()) + ", out_features=" + std::to_string(l.out_features()) +
               ", bias=" + (l.has_bias() ? "True" : "False");
      });

  py::class_<nn::ParallelLinear, nn::UnaryModule, std::shared_ptr<nn::ParallelLinear>>(
      nn_m, "ParallelLinear",
      "M independent linear layers as one batched op: weight [M, in, out], bias [M, 1, out]; input [M, B, in] (one "
      "per layer) or [B, in] (shared) -> [M, B, out]. Layer m is initialised as the m-th of M Linears")
      .def(py::init([](std::int64_t members, std::int64_t in_features, std::int64_t out_features, bool bias,
                       const std::string& dtype, ag::Generator* generator) {
             return converted(std::make_shared<nn::ParallelLinear>(members, in_features, out_features,
                                                                   generator_or_default(generator), bias),
                              dtype);
           }),
           py::arg("members"), py::arg("in_features"), py::arg("out_features"), py::arg("bias") = true,
           py::arg("dtype") = "float32", py::arg("generator") = nullptr)
      .def_property_readonly("members", &nn::ParallelLinear::members)
      .def_property_readonly("in_features", &nn::ParallelLinear::in_features)
      .def_property_readonly("out_features", &nn::ParallelLinear::out_features)
      .def_property_readonly("weight", &nn::ParallelLinear::weight)
      .def_property_readonly("bias",
                             [](const nn::ParallelLinear& l) { return l.has_bias() ? py::cast(l.bias()) : py::none(); })
      .def(
          "reset_parameters",
          [](nn::ParallelLinear& l, ag::Generator* g) { l.reset_parameters(generator_or_default(g)); },
          py::arg("generator") = nullptr)
      .def("extra_repr", [](const nn::ParallelLinear& l) {
        return "members=" + std::to_string(l.members()) + ", in_features=" + std::to_string(l.in_features()) +
               ", out_features=" + std::to_string(l.out_features()) + ", bias=" + (l.has_bias() ? "True" : "False");
      });

  py::class_<nn::MLP, nn::UnaryModule, std::shared_ptr<nn::MLP>>(
      nn_m, "MLP",
      "Linear layers of sizes [in, h1, ..., out] with `activation` ('identity', 'tanh', 'relu', 'sigmoid') between "
      "them (and after the last with activate_last); parameters layers.0.weight, layers.0.bias, ...")
      .def(py::init([](const std::vector<std::int64_t>& sizes, const std::string& activation, bool activate_last,
                       const std::string& dtype, ag::Generator* generator) {
             return converted(
                 std::make_shared<nn::MLP>(sizes, activation, generator_or_default(generator), activate_last), dtype);
           }),
           py::arg("sizes"), py::arg("activation"), py::arg("activate_last") = false, py::arg("dtype") = "float32",
           py::arg("generator") = nullptr)
      .def_property_readonly("sizes", &nn::MLP::sizes)
      .def_property_readonly("activation", [](const nn::MLP& m) { return nn::to_string(m.activation()); })
      .def_property_readonly("activate_last", &nn::MLP::activate_last)
      .def_property_readonly("num_layers", &nn::MLP::num_layers)
      .def(
          "layer",
          [](const nn::MLP& m, std::int64_t i) {
            const std::shared_ptr<nn::Module> layers = child_of(m, 0, "MLP.layer");
            return child_of(*layers, container_index(i, m.num_layers(), "MLP.layer"), "MLP.layer");
          },
          py::arg("i"), "Layer i, a Linear (negative i counts from the end)")
      .def("extra_repr", [](const nn::MLP& m) {
        std::string sizes;
        for (std::int64_t s : m.sizes()) sizes += (sizes.empty() ? "" : ", ") + std::to_string(s);
        return "sizes=[" + sizes + "], activation='" + nn::to_string(m.activation()) +
               "', activate_last=" + (m.activate_last() ? "True" : "False");
      });

  py::class_<nn::Sequential, nn::UnaryModule, std::shared_ptr<nn::Sequential>>(
      nn_m, "Sequential", "Chains modules of one input (children '0', '1', ...), as torch.nn.Sequential")
      .def(py::init([](const py::args& modules) {
        auto sequential = std::make_shared<nn::Sequential>();
        for (std::size_t i = 0; i < modules.size(); ++i)
          sequential->push_back(unary_module(modules[i], "Sequential: module " + std::to_string(i)));
        return sequential;
      }))
      .def(
          "append",
          [](const py::object& self, const py::object& module) {
            auto& sequential = self.cast<nn::Sequential&>();
            sequential.push_back(unary_module(module, "Sequential.append"));
            return self;
          },
          py::arg("module"))
      .def("__len__", &nn::Sequential::size)
      .def("__getitem__", [](const nn::Sequential& s, std::int64_t i) {
        return child_of(s, container_index(i, s.size(), "Sequential"), "Sequential");
      });

  py::class_<nn::ModuleList, nn::Module, std::shared_ptr<nn::ModuleList>>(
      nn_m, "ModuleList", "Holds modules as children '0', '1', ... without calling them, as torch.nn.ModuleList")
      .def(py::init([](const py::object& modules) {
             auto list = std::make_shared<nn::ModuleList>();
             if (!modules.is_none())
               for (const py::handle& module : modules) {
                 const auto object = py::reinterpret_borrow<py::object>(module);
                 if (!py::isinstance<nn::Module>(object))
                   throw py::type_error("ModuleList: expected maps.nn.Modules, got a " +
                                        std::string(py::str(py::type::of(object).attr("__name__"))));
                 list->push_back(keep_python_alive<nn::Module>(object));
               }
             return list;
           }),
           py::arg("modules") = py::none())
      .def(
          "append",
          [](const py::object& self, const py::object& module) {
            if (!py::isinstance<nn::Module>(module))
              throw py::type_error("ModuleList.append: expected a maps.nn.Module");
            self.cast<nn::ModuleList&>().push_back(keep_python_alive<nn::Module>(module));
            return self;
          },
          py::arg("module"))
      .def("__len__", &nn::ModuleList::size)
      .def("__getitem__", [](const nn::ModuleList& l, std::int64_t i) {
        return child_of(l, container_index(i, l.size(), "ModuleList"), "ModuleList");
      });

  py::class_<nn::Tanh, nn::UnaryModule, std::shared_ptr<nn::Tanh>>(nn_m, "Tanh").def(py::init<>());
  py::class_<nn::ReLU, nn::UnaryModule, std::shared_ptr<nn::ReLU>>(nn_m, "ReLU").def(py::init<>());
  py::class_<nn::Sigmoid, nn::UnaryModule, std::shared_ptr<nn::Sigmoid>>(nn_m, "Sigmoid").def(py::init<>());
  py::class_<nn::Identity, nn::UnaryModule, std::shared_ptr<nn::Identity>>(nn_m, "Identity").def(py::init<>());
}

void bind_serialization(py::module_& nn_m) {
  nn_m.def(
      "save",
      [](const py::object& what, const py::object& path, const std::string& config) {
        const std::string file = path_of(path);
        if (py::isinstance<nn::Module>(what))
          nn::save(what.cast<const nn::Module&>(), file, config);
        else
          nn::save_tensors(file, named_tensors(what, "maps.nn.save"), config);
      },
      py::arg("obj"), py::arg("path"), py::arg("config") = "",
      "A module's state_dict(), or a {name: Tensor} dict, to a checkpoint file (maps train's format: written "
      "atomically, checksummed)");
  nn_m.def(
      "load",
      [](const py::object& path, bool with_config) -> py::object {
        const std::string file = path_of(path);
        check_exists(file);
        nn::Checkpoint checkpoint = nn::load_tensors(file);
        py::dict state = named_dict(checkpoint.tensors);
        if (with_config) return py::make_tuple(state, checkpoint.config);
        return state;
      },
      py::arg("path"), py::arg("with_config") = false,
      "A checkpoint file's {name: Tensor} (and its config string with with_config=True); a damaged file is refused "
      "naming it");
}

void bind_nn_utilities(py::module_& nn_m) {
  nn_m.def(
      "clip_grad_norm_",
      [](const py::object& params, double max_norm) {
        return nn::clip_grad_norm_(optimiser_parameters(params, "clip_grad_norm_"), max_norm);
      },
      py::arg("parameters"), py::arg("max_norm"),
      "torch.nn.utils.clip_grad_norm_ (2-norm): scales the grads in place when their norm exceeds max_norm; "
      "returns the norm before");
  nn_m.def(
      "grad_norm", [](const py::object& params) { return nn::grad_norm(optimiser_parameters(params, "grad_norm")); },
      py::arg("parameters"), "The 2-norm of every grad taken together");

  py::module_ init = nn_m.def_submodule("init", "In-place initialisers, as torch.nn.init (under no_grad)");
  init.def(
      "uniform_",
      [](ag::Tensor& t, double a, double b, ag::Generator* g) {
        return nn::init::uniform_(t, a, b, generator_or_default(g));
      },
      py::arg("tensor"), py::arg("a") = 0.0, py::arg("b") = 1.0, py::arg("generator") = nullptr);
  init.def(
      "normal_",
      [](ag::Tensor& t, double mean, double std, ag::Generator* g) {
        return nn::init::normal_(t, mean, std, generator_or_default(g));
      },
      py::arg("tensor"), py::arg("mean") = 0.0, py::arg("std") = 1.0, py::arg("generator") = nullptr);
  init.def("constant_", &nn::init::constant_, py::arg("tensor"), py::arg("val"));
  init.def("zeros_", &nn::init::zeros_, py::arg("tensor"));
  init.def("ones_", &nn::init::ones_, py::arg("tensor"));
  init.def(
      "kaiming_uniform_",
      [](ag::Tensor& t, double a, const std::string& mode, ag::Generator* g) {
        if (mode != "fan_in" && mode != "fan_out")
          throw std::invalid_argument("kaiming_uniform_: mode must be 'fan_in' or 'fan_out', not '" + mode + "'");
        return nn::init::kaiming_uniform_(t, generator_or_default(g), a,
                                          mode == "fan_in" ? nn::init::FanMode::FanIn : nn::init::FanMode::FanOut);
      },
      py::arg("tensor"), py::arg("a") = 0.0, py::arg("mode") = "fan_in", py::arg("generator") = nullptr);
  init.def(
      "xavier_uniform_",
      [](ag::Tensor& t, double gain, ag::Generator* g) {
        return nn::init::xavier_uniform_(t, generator_or_default(g), gain);
      },
      py::arg("tensor"), py::arg("gain") = 1.0, py::arg("generator") = nullptr);
  init.def(
      "orthogonal_",
      [](ag::Tensor& t, double gain, ag::Generator* g) {
        return nn::init::orthogonal_(t, gain, generator_or_default(g));
      },
      py::arg("tensor"), py::arg("gain") = 1.0, py::arg("generator") = nullptr);
  init.def("calculate_gain", &nn::init::calculate_gain, py::arg("nonlinearity"), py::arg("param") = 0.01);
}

void bind_optim(py::module_& optim_m) {
  py::class_<optim::Optimizer, std::shared_ptr<optim::Optimizer>>(
      optim_m, "Optimizer", "Base of the optimisers (one parameter group), after torch.optim.Optimizer")
      .def("step", &optim::Optimizer::step, "Updates the parameters in place from their grads (those without skipped)")
      .def("zero_grad", &optim::Optimizer::zero_grad, "Every parameter's grad to None")
      .def_property("lr", &optim::Optimizer::lr, &optim::Optimizer::set_lr)
      .def_property_readonly("params", &optim::Optimizer::params);

  py::class_<optim::Adam, optim::Optimizer, std::shared_ptr<optim::Adam>>(
      optim_m, "Adam", "torch.optim.Adam (weight_decay: L2 added to the gradient, not AdamW)")
      .def(py::init([](const py::object& params, double lr, std::pair<double, double> betas, double eps,
                       double weight_decay) {
             return std::make_shared<optim::Adam>(optimiser_parameters(params, "Adam"),
                                                  optim::AdamOptions{lr, betas.first, betas.second, eps, weight_decay});
           }),
           py::arg("params"), py::arg("lr") = 1e-3, py::arg("betas") = std::make_pair(0.9, 0.999),
           py::arg("eps") = 1e-8, py::arg("weight_decay") = 0.0)
      .def_property_readonly("betas",
                             [](const optim::Adam& a) { return std::make_pair(a.options().beta1, a.options().beta2); })
      .def_property_readonly("eps", [](const optim::Adam& a) { return a.options().eps; })
      .def_property_readonly("weight_decay", [](const optim::Adam& a) { return a.options().weight_decay; })
      .def("step_count", &optim::Adam::step_count, py::arg("i"), "The steps parameter i has taken")
      .def("set_lr_scale", &optim::Adam::set_lr_scale, py::arg("i"), py::arg("scale"),
           "Parameter i's learning rate is lr times this factor")
      .def("lr_scale", &optim::Adam::lr_scale, py::arg("i"))
      .def(
          "state_dict", [](const optim::Adam& a) { return named_dict(a.state()); },
          "The moments and step counts: {'step.<i>', 'exp_avg.<i>', 'exp_avg_sq.<i>'} for every parameter i that "
          "has stepped (maps.nn.save writes it)")
      .def(
          "load_state_dict",
          [](optim::Adam& a, const py::object& state) { a.load_state(named_tensors(state, "Adam.load_state_dict")); },
          py::arg("state"), "Checked against the parameters; unchanged when anything does not match");

  py::class_<optim::SGD, optim::Optimizer, std::shared_ptr<optim::SGD>>(optim_m, "SGD",
                                                                        "torch.optim.SGD (momentum, dampening, "
                                                                        "nesterov, L2 weight_decay)")
      .def(py::init([](const py::object& params, double lr, double momentum, double dampening, double weight_decay,
                       bool nesterov) {
             return std::make_shared<optim::SGD>(optimiser_parameters(params, "SGD"),
                                                 optim::SGDOptions{lr, momentum, dampening, weight_decay, nesterov});
           }),
           py::arg("params"), py::arg("lr"), py::arg("momentum") = 0.0, py::arg("dampening") = 0.0,
           py::arg("weight_decay") = 0.0, py::arg("nesterov") = false)
      .def_property_readonly("momentum", [](const optim::SGD& s) { return s.options().momentum; })
      .def_property_readonly("weight_decay", [](const optim::SGD& s) { return s.options().weight_decay; });
}

}  // namespace
}  // namespace nn_bindings

void bind_nn(py::module_& m) {
  py::module_ nn_m = m.def_submodule("nn", "The nn layer (python/maps/nn.py wraps it)");
  nn_bindings::bind_module(nn_m);
  nn_bindings::bind_layers(nn_m);
  nn_bindings::bind_serialization(nn_m);
  nn_bindings::bind_nn_utilities(nn_m);
  py::module_ optim_m = m.def_submodule("optim", "The optimisers (python/maps/optim.py wraps them)");
  nn_bindings::bind_optim(optim_m);
}

}  // namespace maps::python
