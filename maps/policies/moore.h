#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "maps/policies/policy.h"

// MOORE (Hendawy, Peters, D'Eramo, ICLR 2024; docs/zoo.md) as a behaviour-cloning policy: k expert MLPs on the state
// alone (ReLU between layers, none after the last), their k outputs made orthonormal per state by Gram-Schmidt, mixed
// by per-task weights w_k = W one_hot(k) (no bias, no softmax), tanh, then one linear head per task.
// Parameters: "experts.<l>.weight/bias" (ParallelLinear [k, in, width]), "task_weights" [K, k], "heads.weight"
// [K, width, A], "heads.bias" [K, 1, A].
namespace maps::core {

struct MOOREConfig {
  std::int64_t experts = 4;  // k (the paper's MT10 setting)
  std::int64_t layers = 3;   // per expert
  std::int64_t width = 400;  // every expert layer's width
  // false: the same network without the orthogonal layer (the mixture-of-experts baseline of MOORE's paper).
  bool orthogonal = true;
};

class MOORE : public Policy {
 public:
  MOORE(PolicyShape shape, const MOOREConfig& config, ag::Generator& gen);

  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  LossTerms loss(const Batch& batch) override;

  // The experts' outputs [k, n, width], orthonormalised per state when configured.
  ag::Tensor expert_outputs(const ag::Tensor& observations);
  // tanh(sum_i w_{k_j, i} u_i) for each row j: [n, width].
  ag::Tensor mixed(const ag::Tensor& outputs, const std::vector<std::int64_t>& tasks);
  // |w_k| / sum |w_k| of each row's task: the share of each expert in the row's mixture.
  ag::Tensor routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  std::int64_t routed_modules() const override { return config_.experts; }

  const MOOREConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<MOORE>(*this); }

 private:
  ag::Tensor predict(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks, std::int64_t per_task);

  MOOREConfig config_;
  std::size_t experts_ = 0;       // child slot: ModuleList of ParallelLinear
  std::size_t task_weights_ = 0;  // parameter slot [K, k]
  std::size_t heads_ = 0;         // child slot: ParallelLinear(K, width, A)
};

// The parameter count of MOORE with this config.
double moore_parameter_count(const PolicyShape& shape, const MOOREConfig& config);

}  // namespace maps::core
