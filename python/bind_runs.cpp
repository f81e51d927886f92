#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <Eigen/Core>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "experiments/run/run_folder.h"
#include "maps/policies/maps_policy.h"
#include "nn/module.h"
#include "python/bindings.h"

namespace py = pybind11;

namespace maps::python {
namespace {

using RowMatrixD = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// A trained run, as `maps eval` loads it, acting on raw observations (it standardises them as training did).
class PythonRun {
 public:
  PythonRun(const std::string& folder, const std::string& checkpoint, const std::string& data_file)
      : folder_(folder), run_(experiments::load_trained_run(folder, checkpoint, data_file)) {}

  const std::string& folder() const { return folder_; }
  std::string method() const { return run_.config.method; }
  std::string config_json() const { return core::to_json(run_.config).dump(); }
  std::string checkpoint_json() const { return run_.best.dump(); }
  const std::string& task_set() const { return run_.data->task_set(); }
  const std::vector<std::string>& task_names() const { return run_.data->task_names(); }
  std::int64_t observation_size() const { return run_.data->observation_size(); }
  std::int64_t action_size() const { return run_.data->action_size(); }
  std::vector<double> demo_mean_returns() const {
    std::vector<double> returns;
    for (int k = 0; k < run_.data->num_tasks(); ++k) returns.push_back(run_.data->demo_mean_return(k));
    return returns;
  }

  RowMatrixD act(const RowMatrixD& observations, const std::vector<std::int64_t>& tasks) {
    const ag::Tensor input = checked_input(observations, tasks, "act");
    ag::NoGradGuard no_grad;
    return ag::to_eigen_double(run_.policy->act(input, tasks));
  }

  RowMatrixD selector_scores(const RowMatrixD& observations, const std::vector<std::int64_t>& tasks) {
    core::MAPSPolicy& policy = maps_policy("selector_scores");
    const ag::Tensor input = checked_input(observations, tasks, "selector_scores");
    ag::NoGradGuard no_grad;
    return ag::to_eigen_double(policy.scores(input, tasks));
  }

  // Any routing method's shares [n, M] (MAPS's scores, the zoo's task weights, attention, gates; docs/zoo.md).
  RowMatrixD routing(const RowMatrixD& observations, const std::vector<std::int64_t>& tasks) {
    if (run_.policy->routed_modules() == 0)
      throw py::type_error("routing: " + folder_ + " is a " + run_.config.method +
                           " run, which has no modules to route between (maps train --help: the zoo's methods and "
                           "MAPS route)");
    const ag::Tensor input = checked_input(observations, tasks, "routing");
    ag::NoGradGuard no_grad;
    return ag::to_eigen_double(run_.policy->routing(input, tasks));
  }

  std::int64_t num_modules() { return maps_policy("num_modules").num_modules(); }
  void force_module(std::int64_t module) {
    core::MAPSPolicy& policy = maps_policy("force_module");
    if (module < -1 || module >= policy.num_modules())
      throw std::out_of_range("force_module: module must be in [0, " + std::to_string(policy.num_modules()) +
                              ") or -1 (the selector's own scores), not " + std::to_string(module));
    policy.force_module(module);
  }
  std::int64_t forced_module() { return maps_policy("forced_module").forced_module(); }

  // The policy as a maps.nn.Module: its parameters are the ones act() and forward() use (sharing storage).
  std::shared_ptr<nn::Module> policy() const { return run_.policy; }

  // The policy's mean actions [n, A] as a tensor on the graph (grad mode as the caller has it), for observations
  // [n, S] standardised as act() does: a maps.Tensor stays on the graph (its gradient flows back through the
  // standardisation), a numpy array is read as act() reads it.
  ag::Tensor forward(const py::object& observations, const std::vector<std::int64_t>& tasks) {
    if (!py::isinstance<ag::Tensor>(observations))
      return run_.policy->act(checked_input(observations.cast<RowMatrixD>(), tasks, "forward"), tasks);
    const ag::Tensor& raw = observations.cast<const ag::Tensor&>();
    const core::DemoDataset& data = *run_.data;
    if (!raw.defined() || raw.dim() != 2 || raw.size(1) != data.observation_size())
      throw std::invalid_argument("forward: observations must be [n, " + std::to_string(data.observation_size()) +
                                  "] for " + folder_ + " (" + data.task_set() + "), got " + ag::shape_text(raw));
    check_tasks(tasks, raw.size(0), "forward");
    for (double v : raw.to_vector())
      if (!std::isfinite(v)) throw std::invalid_argument("forward: observations hold NaN or inf");
    // (x - mean) / std in float64, clamped, as Standardizer::apply computes it, then the policy's dtype.
    const core::Standardizer& standardizer = data.standardizer();
    const ag::Tensor mean = ag::from_eigen(Eigen::MatrixXd(standardizer.mean.transpose()));
    const ag::Tensor scale = ag::from_eigen(Eigen::MatrixXd(standardizer.std.transpose()));
    ag::Tensor input = (raw.to(ag::Dtype::Float64) - mean) / scale;
    if (standardizer.clip > 0.0) input = ag::clamp(input, -standardizer.clip, standardizer.clip);
    input = input.to(policy_dtype());
    return run_.policy->act(input, tasks);
  }

 private:
  core::MAPSPolicy& maps_policy(const char* what) {
    auto* policy = dynamic_cast<core::MAPSPolicy*>(run_.policy.get());
    if (policy == nullptr)
      throw py::type_error(std::string(what) + ": " + folder_ + " is a " + run_.config.method +
                           " run; only MAPS has a selector and modules");
    return *policy;
  }

  // The observations standardised as in training, as a tensor of the policy's dtype (float32, as trained).
  ag::Tensor checked_input(const RowMatrixD& observations, const std::vector<std::int64_t>& tasks,
                           const char* what) const {
    const core::DemoDataset& data = *run_.data;
    if (observations.cols() != data.observation_size())
      throw std::invalid_argument(std::string(what) + ": observations have " + std::to_string(observations.cols()) +
                                  " columns; " + folder_ + " expects " + std::to_string(data.observation_size()) +
                                  " (" + data.task_set() + ")");
    check_tasks(tasks, observations.rows(), what);
    if (!observations.allFinite()) throw std::invalid_argument(std::string(what) + ": observations hold NaN or inf");
    return data.standardizer().apply(Eigen::MatrixXd(observations), policy_dtype());
  }

  void check_tasks(const std::vector<std::int64_t>& tasks, std::int64_t rows, const char* what) const {
    const core::DemoDataset& data = *run_.data;
    if (static_cast<std::int64_t>(tasks.size()) != rows)
      throw std::invalid_argument(std::string(what) + ": " + std::to_string(tasks.size()) + " task indices for " +
                                  std::to_string(rows) + " observations");
    for (std::int64_t task : tasks)
      if (task < 0 || task >= data.num_tasks())
        throw std::out_of_range(std::string(what) + ": task index " + std::to_string(task) + " is not in [0, " +
                                std::to_string(data.num_tasks()) + ") (" + data.task_set() + ")");
  }

  // The dtype the policy computes in: float32 as trained, float64 after run.policy.to("float64").
  ag::Dtype policy_dtype() const {
    const std::vector<ag::Tensor> parameters = run_.policy->parameters();
    return parameters.empty() ? ag::Dtype::Float32 : parameters.front().dtype();
  }

  std::string folder_;
  experiments::TrainedRun run_;
};

}  // namespace

void bind_runs(py::module_& m) {
  py::class_<PythonRun>(m, "_Run")
      .def(py::init<const std::string&, const std::string&, const std::string&>(), py::arg("folder"),
           py::arg("checkpoint") = core::run_files::kBestCheckpoint, py::arg("data_file") = "",
           py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("folder", &PythonRun::folder)
      .def_property_readonly("method", &PythonRun::method)
      .def_property_readonly("config_json", &PythonRun::config_json)
      .def_property_readonly("checkpoint_json", &PythonRun::checkpoint_json)
      .def_property_readonly("task_set", &PythonRun::task_set)
      .def_property_readonly("task_names", &PythonRun::task_names)
      .def_property_readonly("observation_size", &PythonRun::observation_size)
      .def_property_readonly("action_size", &PythonRun::action_size)
      .def_property_readonly("demo_mean_returns", &PythonRun::demo_mean_returns)
      .def("act", &PythonRun::act, py::arg("observations"), py::arg("tasks"), py::call_guard<py::gil_scoped_release>())
      .def("selector_scores", &PythonRun::selector_scores, py::arg("observations"), py::arg("tasks"),
           py::call_guard<py::gil_scoped_release>())
      .def("routing", &PythonRun::routing, py::arg("observations"), py::arg("tasks"),
           py::call_guard<py::gil_scoped_release>())
      .def_property_readonly("num_modules", &PythonRun::num_modules)
      .def("force_module", &PythonRun::force_module, py::arg("module"))
      .def_property_readonly("forced_module", &PythonRun::forced_module)
      .def_property_readonly("policy", &PythonRun::policy)
      .def("forward", &PythonRun::forward, py::arg("observations"), py::arg("tasks"));
}

}  // namespace maps::python
