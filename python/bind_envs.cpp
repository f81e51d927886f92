#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Core>
#include <memory>
#include <random>
#include <string>

#include "envs/task_expert.h"
#include "envs/task_sets.h"
#include "python/bindings.h"

namespace py = pybind11;

namespace maps::python {
namespace {

// A task's expert with its own noise generator, so sample_action is reproducible from a seed.
struct PythonExpert {
  envs::TaskExpert expert;
  std::mt19937_64 rng;
};

}  // namespace

void bind_envs(py::module_& m) {
  m.def("task_set_names", &envs::task_set_names, "The task sets: gravity, modified, mt10");
  m.def("task_names", &envs::task_names, py::arg("task_set"), "A set's tasks in task-index order");
  m.def("task_set_of", &envs::task_set_of, py::arg("task"));
  m.def("task_index", &envs::task_index, py::arg("task"));

  py::class_<envs::Env>(m, "_Env", "A task's MuJoCo environment (maps.make_env wraps it Gymnasium-style)")
      .def_property_readonly("task", [](const envs::Env& env) { return env.spec().task; })
      .def_property_readonly("task_index", [](const envs::Env& env) { return env.spec().task_index; })
      .def_property_readonly("observation_size", [](const envs::Env& env) { return env.spec().observation_size; })
      .def_property_readonly("action_size", [](const envs::Env& env) { return env.spec().action_size; })
      .def_property_readonly("action_low", [](const envs::Env& env) { return env.spec().action_low; })
      .def_property_readonly("action_high", [](const envs::Env& env) { return env.spec().action_high; })
      .def_property_readonly("horizon", [](const envs::Env& env) { return env.spec().horizon; })
      .def("reset", &envs::Env::reset, py::arg("seed"), py::call_guard<py::gil_scoped_release>())
      .def(
          "step",
          [](envs::Env& env, const Eigen::VectorXd& action) {
            envs::StepResult result;
            {
              py::gil_scoped_release release;
              result = env.step(action);
            }
            return py::make_tuple(result.observation, result.reward, result.terminated, result.truncated,
                                  result.success, env.in_failure_state());
          },
          py::arg("action"),
          "(observation, reward, terminated, truncated, success, in_failure_state); actions outside the bounds are "
          "clipped");
  m.def("_make_env", &envs::make_env, py::arg("task"));

  py::class_<PythonExpert>(m, "_Expert")
      .def_property_readonly("task", [](const PythonExpert& e) { return e.expert.task; })
      .def_property_readonly("source", [](const PythonExpert& e) { return e.expert.source; })
      .def_property_readonly("documented_return", [](const PythonExpert& e) { return e.expert.documented_return; })
      .def(
          "act", [](const PythonExpert& e, const Eigen::VectorXd& obs) { return e.expert.mean_action(obs); },
          py::arg("observation"), "The expert's deterministic (mean) action")
      .def(
          "sample", [](PythonExpert& e, const Eigen::VectorXd& obs) { return e.expert.sample_action(obs, e.rng); },
          py::arg("observation"), "The mean action plus the expert's exploration noise");
  m.def(
      "_load_expert",
      [](const std::string& task, std::uint64_t seed) {
        return PythonExpert{envs::load_task_expert(task), std::mt19937_64(seed)};
      },
      py::arg("task"), py::arg("seed") = 0);
}

}  // namespace maps::python
