#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "envs/demo_file.h"
#include "python/bindings.h"

namespace py = pybind11;

namespace maps::python {
namespace {

envs::EpisodeEnd parse_episode_end(const std::string& name) {
  if (name == "terminated") return envs::EpisodeEnd::kTerminated;
  if (name == "truncated") return envs::EpisodeEnd::kTruncated;
  if (name == "unknown") return envs::EpisodeEnd::kUnknown;
  throw std::invalid_argument("Demonstration.end must be 'terminated', 'truncated' or 'unknown', not '" + name + "'");
}

}  // namespace

void bind_demos(py::module_& m) {
  py::class_<envs::Demonstration>(m, "Demonstration", "One episode of one task; row t of every array is step t")
      .def(py::init<>())
      .def_readwrite("task", &envs::Demonstration::task)
      .def_readwrite("task_index", &envs::Demonstration::task_index)
      .def_readwrite("seed", &envs::Demonstration::seed, "The seed env.reset(seed=...) drew its initial state with")
      .def_readwrite("obs", &envs::Demonstration::obs, "[T, obs_dim] float64")
      .def_readwrite("actions", &envs::Demonstration::actions, "[T, act_dim] float64")
      .def_readwrite("rewards", &envs::Demonstration::rewards, "[T] float64")
      .def_property(
          "dones",
          [](const envs::Demonstration& d) {
            py::array_t<bool> dones(static_cast<py::ssize_t>(d.dones.size()));
            for (std::size_t t = 0; t < d.dones.size(); ++t) dones.mutable_at(t) = d.dones[t] != 0;
            return dones;
          },
          [](envs::Demonstration& d, const py::array_t<std::uint8_t, py::array::forcecast>& dones) {
            if (dones.ndim() != 1) throw std::invalid_argument("Demonstration.dones must be 1-d");
            d.dones.assign(dones.data(), dones.data() + dones.size());
          },
          "[T] bool: the episode ended after step t")
      .def_readwrite("episode_return", &envs::Demonstration::episode_return)
      .def_readwrite("success", &envs::Demonstration::success)
      .def_readwrite("final_obs", &envs::Demonstration::final_obs,
                     "The observation after the last step (empty for format 1 files)")
      .def_property(
          "end", [](const envs::Demonstration& d) { return std::string(envs::episode_end_name(d.end)); },
          [](envs::Demonstration& d, const std::string& end) { d.end = parse_episode_end(end); },
          "'terminated' (a terminal state of the task), 'truncated' (the time limit) or 'unknown' (format 1)")
      .def_property_readonly("num_samples", &envs::Demonstration::num_samples)
      .def("__repr__", [](const envs::Demonstration& d) {
        return "<Demonstration " + d.task + " seed " + std::to_string(d.seed) + ", " + std::to_string(d.num_samples()) +
               " steps>";
      });

  py::class_<envs::DemoFile>(m, "DemoFile", "A demo file's demonstrations, train/valid split and metadata")
      .def(py::init<>())
      .def_readwrite("task_set", &envs::DemoFile::task_set)
      .def_readwrite("task_names", &envs::DemoFile::task_names)
      .def_readwrite("env_version", &envs::DemoFile::env_version)
      .def_readwrite("creation_command", &envs::DemoFile::creation_command)
      .def_readwrite("extra_json", &envs::DemoFile::extra_json)
      .def_readwrite("train", &envs::DemoFile::train, "Indices into demos (mask/train)")
      .def_readwrite("valid", &envs::DemoFile::valid, "Indices into demos (mask/valid)")
      .def_readonly("format_version", &envs::DemoFile::format_version)
      .def_property(
          "demos",
          [](py::object self) {
            auto& file = self.cast<envs::DemoFile&>();
            py::list demos;
            for (envs::Demonstration& d : file.demos)
              demos.append(py::cast(&d, py::return_value_policy::reference_internal, self));
            return demos;
          },
          [](envs::DemoFile& file, const std::vector<envs::Demonstration>& demos) { file.demos = demos; },
          "The demonstrations (demos[i] is data/demo_<i>); elements are views into the file object")
      .def_property_readonly("total_samples", &envs::DemoFile::total_samples)
      .def("__len__", [](const envs::DemoFile& f) { return f.demos.size(); })
      .def("__repr__", [](const envs::DemoFile& f) {
        return "<DemoFile " + f.task_set + ": " + std::to_string(f.demos.size()) + " demos, " +
               std::to_string(f.total_samples()) + " samples, format " + std::to_string(f.format_version) + ">";
      });

  m.def("read_demo_file", &envs::read_demo_file, py::arg("path"), py::call_guard<py::gil_scoped_release>(),
        "Reads and validates a demo file (HDF5, format 1 or 2); errors name the file and the object");
  m.def("write_demo_file", &envs::write_demo_file, py::arg("path"), py::arg("file"),
        py::call_guard<py::gil_scoped_release>(), "Validates, then writes format 2 atomically");
}

}  // namespace maps::python
