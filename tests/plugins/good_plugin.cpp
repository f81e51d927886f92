// A plugin as a user writes one: a selector loss, a small method and a task set, registered by name. The loader's
// tests load it into the test program; tests/experiments/plugin_task_set_test.py collects, trains and evaluates with
// it through the tool.

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "envs/half_cheetah.h"
#include "envs/task_sets.h"
#include "maps/plugin.h"
#include "maps/policies/baseline_util.h"
#include "maps/policies/policy_registry.h"
#include "maps/selector/selector_loss.h"
#include "nn/linear.h"

MAPS_PLUGIN();

namespace {

namespace ag = maps::ag;
using maps::core::LossTerms;
using maps::core::PolicyShape;

// The mean of the squared scores: smallest when every module is used alike.
class SquaredScoresLoss : public maps::core::SelectorLoss {
 public:
  SquaredScoresLoss() : SelectorLoss("SquaredScoresLoss") {}
  std::string name() const override { return "plugin_squared_scores"; }
  ag::Tensor forward(const maps::core::SelectorOutputs& outputs) override {
    return ag::mean(outputs.scores * outputs.scores);
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<SquaredScoresLoss>(*this); }
};

// One linear map from [state, one-hot task] to the action.
class LinearPolicy : public maps::core::Policy {
 public:
  LinearPolicy(PolicyShape shape, ag::Generator& gen) : Policy("LinearPolicy", shape) {
    linear_ = register_module(
        "linear", std::make_shared<maps::nn::Linear>(shape.observation_size + shape.num_tasks, shape.action_size, gen));
  }
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override {
    maps::core::detail::check_observations("LinearPolicy::act", shape(), observations, tasks);
    return forward(observations, tasks);
  }
  LossTerms loss(const maps::core::Batch& batch) override {
    maps::core::detail::check_batch("LinearPolicy::loss", shape(), batch);
    return maps::core::detail::bc_terms(bc_loss(forward(batch.observations, batch.tasks), batch));
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<LinearPolicy>(*this); }

 private:
  ag::Tensor forward(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) {
    const ag::Tensor onehot = ag::one_hot(tasks, shape().num_tasks, observations.dtype());
    return child_at<maps::nn::Linear>(linear_).forward(ag::concat({observations, onehot}, 1));
  }
  std::size_t linear_ = 0;
};

maps::core::PolicyMethod linear_method() {
  maps::core::PolicyMethod method;
  method.name = "plugin_linear";
  method.summary = "a linear map of [state, one-hot task] (a test plugin's method)";
  method.parameters = [](const PolicyShape& shape, const maps::core::MethodOptions&) {
    return maps::core::mlp_parameter_count({shape.observation_size + shape.num_tasks, shape.action_size});
  };
  method.size_keys = "(none: the state, task and action sizes)";
  method.make = [](const PolicyShape& shape, const maps::core::MethodOptions&, ag::Generator& gen) {
    return std::shared_ptr<maps::core::Policy>(std::make_shared<LinearPolicy>(shape, gen));
  };
  return method;
}

// Two HalfCheetahs under gravities between Gravity's, demonstrated by Gravity's g = 1.0 expert.
maps::envs::TaskSetDefinition cheetah_set() {
  maps::envs::TaskSetDefinition set;
  set.name = "plugin_cheetah";
  for (const auto& entry : {std::pair<std::string, double>{"plugin_cheetah/g0_9", 0.9}, {"plugin_cheetah/g1_1", 1.1}}) {
    const std::string task = entry.first;  // copies: a lambda cannot capture a structured binding before clang 16
    const double scale = entry.second;
    set.tasks.push_back(
        {task,
         [scale](const std::string& name, std::int64_t index) -> std::unique_ptr<maps::envs::Env> {
           return std::make_unique<maps::envs::HalfCheetahEnv>(name, index, maps::envs::HalfCheetahVariant{scale, {}});
         },
         [task] {
           maps::envs::TaskExpert expert = maps::envs::load_task_expert("gravity/1.0");
           expert.task = task;
           return expert;
         }});
  }
  return set;
}

}  // namespace

MAPS_REGISTER_TASK_SET(cheetah_set());
MAPS_REGISTER_SELECTOR_LOSS("plugin_squared_scores", [] { return std::make_shared<SquaredScoresLoss>(); });
MAPS_REGISTER_POLICY_METHOD(linear_method());
