// Selector losses and methods written in Python, and maps.train: the user's pieces are Python classes, the training
// loop is the C++ one `maps train` runs (experiments/run/train_run.h), which calls back into Python only for them.

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "experiments/process/file_digest.h"
#include "experiments/process/plugins.h"
#include "experiments/run/train_run.h"
#include "io/registry.h"
#include "maps/policies/policy_registry.h"
#include "maps/selector/selector_loss.h"
#include "python/bindings.h"

namespace py = pybind11;

namespace maps::python {
namespace training_bindings {

// The refusal of a Python class defined as a C++ module would not be: modules of Python code cannot be cloned.
[[noreturn]] void refuse_clone(const std::string& type_name) {
  throw std::logic_error(type_name + ": a module defined in Python cannot be cloned (C++ cannot copy its Python part)");
}

class PythonSelectorLoss : public core::SelectorLoss {
 public:
  explicit PythonSelectorLoss(std::string type_name) : SelectorLoss(std::move(type_name)) {}

  std::string name() const override { return registered_name.empty() ? type_name() : registered_name; }
  ag::Tensor forward(const core::SelectorOutputs& outputs) override {
    PYBIND11_OVERRIDE_PURE(ag::Tensor, core::SelectorLoss, forward, outputs);
  }

  using nn::Module::register_buffer;
  using nn::Module::register_module;
  using nn::Module::register_parameter;
  std::string registered_name;  // the name the registry knows it by

 protected:
  std::shared_ptr<Module> shallow_copy() const override { refuse_clone(type_name()); }
};

// What a Python policy's loss(batch) returns, as the trainer's LossTerms: a scalar Tensor (its BC loss), or a dict of
// named scalar terms whose sum is minimised ({"bc": ..., "l2": ...}).
core::LossTerms loss_terms_of(const py::object& result, const std::string& type_name) {
  if (py::isinstance<ag::Tensor>(result)) {
    const ag::Tensor total = result.cast<ag::Tensor>();
    return {total, {{"bc", total}}};
  }
  if (py::isinstance<py::dict>(result) && py::len(result) > 0) {
    core::LossTerms terms;
    for (const auto& [key, value] : result.cast<py::dict>()) {
      if (!py::isinstance<py::str>(key) || !py::isinstance<ag::Tensor>(value))
        throw py::type_error(type_name + ".loss(batch): a dict of loss terms maps names (str) to maps.Tensor");
      const ag::Tensor term = value.cast<ag::Tensor>();
      terms.terms.emplace_back(key.cast<std::string>(), term);
      terms.total = terms.total.defined() ? terms.total + term : term;
    }
    return terms;
  }
  throw py::type_error(type_name + ".loss(batch) returned " + std::string(py::str(result.get_type())) +
                       "; expected a maps.Tensor (the BC loss) or a non-empty dict of named maps.Tensor terms");
}

class PythonPolicy : public core::Policy {
 public:
  PythonPolicy(core::PolicyShape shape, std::string type_name) : Policy(std::move(type_name), shape) {}

  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override {
    PYBIND11_OVERRIDE_PURE(ag::Tensor, core::Policy, act, observations, tasks);
  }
  core::LossTerms loss(const core::Batch& batch) override {
    py::gil_scoped_acquire gil;
    const py::function override = py::get_override(static_cast<const core::Policy*>(this), "loss");
    if (!override) throw std::logic_error(type_name() + " defines no loss(self, batch)");
    return loss_terms_of(override(batch), type_name());
  }

  using core::Policy::bc_loss;
  using nn::Module::register_buffer;
  using nn::Module::register_module;
  using nn::Module::register_parameter;

 protected:
  std::shared_ptr<Module> shallow_copy() const override { refuse_clone(type_name()); }
};

// The Python-defined object behind a C++ reference (a method pybind11 hands the registered base type).
template <typename Python, typename Base>
Python& defined_in_python(Base& object, const char* what) {
  auto* python = dynamic_cast<Python*>(&object);
  if (python == nullptr)
    throw py::type_error(object.type_name() + "." + what + "(): only a class defined in Python has it");
  return *python;
}

// Where a Python class's code is, for provenance: its source file and that file's digest.
void record_python_code(const py::object& cls, const std::string& registered) {
  // Inside a Python plugin the tool is loading, the loader records the file itself.
  if (!io::loading_origin().empty()) return;
  std::string file;
  try {
    file = py::str(py::module_::import("inspect").attr("getsourcefile")(cls));
  } catch (const py::error_already_set&) {
    file = "";  // defined at an interactive prompt: no file to name
  }
  experiments::LoadedPlugin code;
  code.version = "python";
  code.registered = {registered + " (" + std::string(py::str(cls.attr("__module__"))) + "." +
                     std::string(py::str(cls.attr("__qualname__"))) + ")"};
  if (file.empty() || file == "None") {
    code.path = "<python: " + std::string(py::str(cls.attr("__module__"))) + ">";
  } else {
    code.path = file;
    code.sha256 = experiments::sha256_of_file(file);
  }
  experiments::record_external_code(code);
}

// A class registered again under the same name (a module imported, then named by a config's plugins too) is the
// same piece: its second registration does nothing. Another class under a taken name is refused by the registry.
bool registered_before(const std::string& kind, const std::string& name, const py::object& cls) {
  static std::map<std::string, std::string> classes;  // "<kind> <name>" -> the class's module and qualified name
  const std::string key = kind + " " + name;
  const std::string identity =
      std::string(py::str(cls.attr("__module__"))) + "." + std::string(py::str(cls.attr("__qualname__")));
  const auto found = classes.find(key);
  if (found != classes.end() && found->second == identity) return true;
  if (found == classes.end()) classes.emplace(key, identity);
  return false;
}

void register_python_selector_loss(const std::string& name, const py::object& cls) {
  const py::object base = py::module_::import("maps._maps").attr("SelectorLoss");
  if (!py::isinstance<py::type>(cls) || !PyObject_IsSubclass(cls.ptr(), base.ptr()))
    throw py::type_error("register_selector_loss('" + name + "'): expected a subclass of maps.SelectorLoss, got " +
                         std::string(py::repr(cls)));
  if (registered_before("selector loss", name, cls)) return;
  auto* keep_class = new py::object(cls);  // never freed: the registry outlives the interpreter
  core::register_selector_loss(name, [keep_class, name]() -> std::shared_ptr<core::SelectorLoss> {
    py::gil_scoped_acquire gil;
    const py::object instance = (*keep_class)();
    auto* loss = dynamic_cast<PythonSelectorLoss*>(instance.cast<core::SelectorLoss*>());
    if (loss == nullptr) throw std::logic_error("selector loss '" + name + "': its class made no maps.SelectorLoss");
    loss->registered_name = name;
    return keep_python_alive<core::SelectorLoss>(instance);
  });
  record_python_code(cls, "selector loss " + name);
}

std::shared_ptr<core::Policy> make_python_policy(const py::object& cls, const std::string& name,
                                                 const core::PolicyShape& shape, ag::Generator& generator) {
  py::gil_scoped_acquire gil;
  const py::object instance = cls(shape, py::cast(&generator, py::return_value_policy::reference));
  auto* policy = dynamic_cast<PythonPolicy*>(instance.cast<core::Policy*>());
  if (policy == nullptr) throw std::logic_error("method '" + name + "': its class made no maps.Policy");
  if (policy->shape().observation_size != shape.observation_size || policy->shape().action_size != shape.action_size ||
      policy->shape().num_tasks != shape.num_tasks)
    throw std::invalid_argument("method '" + name +
                                "': its policy was not built for the shape it was given (pass "
                                "the shape to maps.Policy.__init__)");
  return keep_python_alive<core::Policy>(instance);
}

void register_python_method(const std::string& name, const py::object& cls, const std::string& summary) {
  const py::object base = py::module_::import("maps._maps").attr("Policy");
  if (!py::isinstance<py::type>(cls) || !PyObject_IsSubclass(cls.ptr(), base.ptr()))
    throw py::type_error("register_method('" + name + "'): expected a subclass of maps.Policy, got " +
                         std::string(py::repr(cls)));
  if (registered_before("method", name, cls)) return;
  auto* keep_class = new py::object(cls);  // never freed: the registry outlives the interpreter
  core::PolicyMethod method;
  method.name = name;
  method.summary =
      summary.empty() ? "a method defined in Python (" + std::string(py::str(cls.attr("__qualname__"))) + ")" : summary;
  method.size_keys = "(the Python class's own)";
  // Counted on a policy built for the purpose: Python code has no count of its own before it allocates.
  method.parameters = [keep_class, name](const core::PolicyShape& shape, const core::MethodOptions&) {
    ag::Generator generator(0);
    return static_cast<double>(make_python_policy(*keep_class, name, shape, generator)->parameter_count());
  };
  method.make = [keep_class, name](const core::PolicyShape& shape, const core::MethodOptions&,
                                   ag::Generator& generator) {
    return make_python_policy(*keep_class, name, shape, generator);
  };
  core::register_policy_method(std::move(method));
  record_python_code(cls, "method " + name);
}

// A config's Python plugin run in this interpreter (maps.train): the file's code registers its pieces.
// Module.register_parameter on a class defined in Python: the registered Tensor, the module's own handle.
template <typename Python, typename Base>
ag::Tensor register_python_parameter(Base& object, const std::string& name, ag::Tensor tensor, bool requires_grad) {
  Python& self = defined_in_python<Python>(object, "register_parameter");
  const std::size_t slot =
      self.register_parameter(name, std::move(tensor), requires_grad);  // first: a[b] reads a first
  return self.named_parameters(false)[slot].tensor;
}

}  // namespace training_bindings

void run_python_plugin_file(const std::string& path) {
  py::gil_scoped_acquire gil;
  try {
    py::module_::import("maps").attr("_load_plugin_file")(path);
  } catch (const py::error_already_set& e) {
    throw std::runtime_error(e.what());
  }
}

void bind_training(py::module_& m) {
  using namespace training_bindings;
  experiments::set_python_plugin_runner(&run_python_plugin_file);
  py::class_<core::PolicyShape>(m, "PolicyShape", "The sizes a policy is built for")
      .def(py::init([](std::int64_t observation_size, std::int64_t action_size, std::int64_t num_tasks) {
             return core::PolicyShape{observation_size, action_size, num_tasks};
           }),
           py::arg("observation_size"), py::arg("action_size"), py::arg("num_tasks"))
      .def_readonly("observation_size", &core::PolicyShape::observation_size)
      .def_readonly("action_size", &core::PolicyShape::action_size)
      .def_readonly("num_tasks", &core::PolicyShape::num_tasks)
      .def("__repr__", [](const core::PolicyShape& s) {
        return "PolicyShape(observation_size=" + std::to_string(s.observation_size) +
               ", action_size=" + std::to_string(s.action_size) + ", num_tasks=" + std::to_string(s.num_tasks) + ")";
      });

  py::class_<core::SelectorOutputs>(
      m, "SelectorOutputs",
      "MAPS's selector scores for one batch of b states of K tasks over M modules (what a selector loss is given)")
      .def(py::init([](const ag::Tensor& scores, const std::vector<std::int64_t>& tasks, std::int64_t num_tasks,
                       const std::optional<ag::Tensor>& all_task_scores,
                       const std::optional<ag::Tensor>& previous_scores) {
             if (!scores.defined() || scores.dim() != 2)
               throw py::value_error("SelectorOutputs: scores must be a [b, M] Tensor");
             if (static_cast<std::int64_t>(tasks.size()) != scores.shape()[0])
               throw py::value_error("SelectorOutputs: tasks must give one task per row of scores (" +
                                     std::to_string(scores.shape()[0]) + "), not " + std::to_string(tasks.size()));
             for (const std::int64_t task : tasks)
               if (task < 0 || task >= num_tasks)
                 throw py::value_error("SelectorOutputs: task " + std::to_string(task) + " is not in [0, " +
                                       std::to_string(num_tasks) + ")");
             return core::SelectorOutputs{scores,
                                          all_task_scores.value_or(ag::Tensor()),
                                          previous_scores.value_or(ag::Tensor()),
                                          tasks,
                                          num_tasks,
                                          scores.shape()[1]};
           }),
           py::arg("scores"), py::arg("tasks"), py::arg("num_tasks"), py::arg("all_task_scores") = std::nullopt,
           py::arg("previous_scores") = std::nullopt,
           "Outputs for a loss's tests and gradient checks (MAPS makes them while training)")
      .def_readonly("scores", &core::SelectorOutputs::scores, "[b, M]: each state's scores under its own task")
      .def_readonly("all_task_scores", &core::SelectorOutputs::all_task_scores, "[K, b, M]: under every task")
      .def_readonly("previous_scores", &core::SelectorOutputs::previous_scores,
                    "[b, M]: the state before each one in its demonstration")
      .def_readonly("tasks", &core::SelectorOutputs::tasks, "[b] task indices")
      .def_readonly("num_tasks", &core::SelectorOutputs::num_tasks)
      .def_readonly("num_modules", &core::SelectorOutputs::num_modules);

  py::class_<core::Batch>(m, "Batch", "A training batch of standardised state-action pairs")
      .def_readonly("observations", &core::Batch::observations, "[n, S]")
      .def_readonly("previous_observations", &core::Batch::previous_observations, "[n, S]")
      .def_readonly("actions", &core::Batch::actions, "[n, A]")
      .def_readonly("tasks", &core::Batch::tasks, "[n] task indices")
      .def_readonly("per_task", &core::Batch::per_task, "rows per task when balanced (task-major), else 0")
      .def("__len__", &core::Batch::size);

  py::class_<core::SelectorLoss, nn::Module, PythonSelectorLoss, std::shared_ptr<core::SelectorLoss>>(
      m, "SelectorLoss",
      "Base of a selector loss: define forward(self, outputs: SelectorOutputs) -> scalar Tensor, and register the "
      "class with maps.register_selector_loss(name, cls)")
      .def(py::init_alias<std::string>(), py::arg("type_name") = "SelectorLoss")
      .def("name", &core::SelectorLoss::name)
      .def("forward", &core::SelectorLoss::forward, py::arg("outputs"))
      .def("__call__", &core::SelectorLoss::forward, py::arg("outputs"))
      .def("register_parameter", &register_python_parameter<PythonSelectorLoss, core::SelectorLoss>, py::arg("name"),
           py::arg("tensor"), py::arg("requires_grad") = true);

  py::class_<core::Policy, nn::Module, PythonPolicy, std::shared_ptr<core::Policy>>(
      m, "Policy",
      "Base of a multi-task policy: __init__(self, shape, generator) calls super().__init__(shape), registers its "
      "parameters and modules; act(self, observations, tasks) -> [n, A] actions; loss(self, batch) -> a scalar "
      "Tensor or a dict of named terms. Register the class with maps.register_method(name, cls)")
      .def(py::init_alias<core::PolicyShape, std::string>(), py::arg("shape"), py::arg("type_name") = "Policy")
      .def_property_readonly("shape", &core::Policy::shape)
      .def("act", &core::Policy::act, py::arg("observations"), py::arg("tasks"))
      .def(
          "loss", [](core::Policy& self, const core::Batch& batch) { return self.loss(batch).total; }, py::arg("batch"))
      .def(
          "bc_loss",
          [](core::Policy& policy, const ag::Tensor& mean_actions, const core::Batch& batch) {
            PythonPolicy& self = defined_in_python<PythonPolicy>(policy, "bc_loss");
            return self.bc_loss(mean_actions, batch);
          },
          py::arg("mean_actions"), py::arg("batch"),
          "The BC loss of predicted mean actions [n, A] against the batch's (train.bc_loss: mean, or sampled)")
      .def("register_parameter", &register_python_parameter<PythonPolicy, core::Policy>, py::arg("name"),
           py::arg("tensor"), py::arg("requires_grad") = true)
      .def(
          "register_buffer",
          [](core::Policy& policy, const std::string& name, const ag::Tensor& tensor) {
            PythonPolicy& self = defined_in_python<PythonPolicy>(policy, "register_buffer");
            const std::size_t slot = self.register_buffer(name, tensor);
            return self.named_buffers(false)[slot].tensor;
          },
          py::arg("name"), py::arg("tensor"))
      .def(
          "register_module",
          [](core::Policy& policy, const std::string& name, const py::object& child) {
            PythonPolicy& self = defined_in_python<PythonPolicy>(policy, "register_module");
            if (!py::isinstance<nn::Module>(child))
              throw py::type_error(self.type_name() + ".register_module(\"" + name + "\"): expected a maps.nn.Module");
            self.register_module(name, keep_python_alive<nn::Module>(child));
            return child;
          },
          py::arg("name"), py::arg("module"));

  m.def("_register_selector_loss", &register_python_selector_loss, py::arg("name"), py::arg("cls"));
  m.def("_register_method", &register_python_method, py::arg("name"), py::arg("cls"), py::arg("summary") = "");
  m.def("selector_loss_names", [] {
    std::vector<std::string> names;
    for (const auto& loss : core::selector_losses()) names.push_back(loss.name);
    return names;
  });
  m.def("method_names", &core::policy_method_names);
  m.def("selector_loss_origin", &core::selector_loss_origin, py::arg("name"));
  m.def("method_origin", &core::policy_method_origin, py::arg("name"));
  m.def("_make_selector_loss", &core::make_selector_loss, py::arg("name"));
  m.def(
      "_train",
      [](const std::string& config_json, const std::string& config_path, const std::string& out,
         const std::vector<std::string>& overrides, int threads, bool print_config) {
        experiments::TrainRunOptions options;
        if (config_json.empty()) {
          options.config_path = config_path;
        } else {
          options.config = nlohmann::json::parse(config_json);
          options.config_path = "maps.train(config)";
        }
        options.out = out;
        options.overrides = overrides;
        options.threads = threads;
        options.print_config = print_config;
        py::gil_scoped_release release;  // the loop is C++; the user's Python pieces take the GIL when called
        return experiments::run_train(options);
      },
      py::arg("config_json"), py::arg("config_path"), py::arg("out"), py::arg("overrides"), py::arg("threads"),
      py::arg("print_config"));
}

}  // namespace maps::python
