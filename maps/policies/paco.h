#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "maps/policies/policy.h"

// PaCo (Sun, Zhang, Xu, Tomizuka, NeurIPS 2022; docs/zoo.md) as a behaviour-cloning policy: every layer of an MLP
// on the state holds P parameter sets phi_1..phi_P, and task k uses theta_k = sum_p w_{k,p} phi_p, with
// w_k = W one_hot(k) + b unnormalised (identity output). Layers: `layers` hidden of `width` (ReLU) and the output.
// Parameters: "sets.<l>.weight" [P, in, out], "sets.<l>.bias" [P, 1, out], "task_weights" [K, P], "task_bias" [P].
//
// PaCo's loss masking: a task whose mean BC loss in the batch exceeds mask_threshold is left out of that step's
// loss, and after the step its task weights are replaced by a random convex combination of the other tasks'
// ("interpolate") or one of them ("copy").
namespace maps::core {

struct PaCoConfig {
  std::int64_t parameter_sets = 5;  // P (the paper's MT10 setting)
  std::int64_t layers = 3;          // hidden layers
  std::int64_t width = 400;
  bool identical_init = true;         // every set starts as the first (the public code's use_identical_init)
  double mask_threshold = 30.0;       // 0: never mask
  std::string reset = "interpolate";  // or "copy"
};

class PaCo : public Policy {
 public:
  PaCo(PolicyShape shape, const PaCoConfig& config, ag::Generator& gen);

  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  // terms {"bc", "masked_tasks"} (the number of tasks the step left out).
  LossTerms loss(const Batch& batch) override;
  void after_step() override;
  // |w_k| / sum |w_k| of each row's task.
  ag::Tensor routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  std::int64_t routed_modules() const override { return config_.parameter_sets; }

  // Every task's weights w_k [K, P].
  ag::Tensor task_weights() const;
  const PaCoConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<PaCo>(*this); }

 private:
  // Each task's network on inputs [K, n, in] (or [n, in], the same rows for every task) -> [K, n, A].
  ag::Tensor run(const ag::Tensor& x);

  PaCoConfig config_;
  std::size_t sets_ = 0;  // child slot: ModuleList of ParallelLinear(P, in, out)
  std::size_t task_weights_ = 0, task_bias_ = 0;
  std::vector<std::int64_t> masked_;  // the tasks the last loss() left out
  std::uint64_t reset_seed_ = 0;
};

double paco_parameter_count(const PolicyShape& shape, const PaCoConfig& config);

}  // namespace maps::core
