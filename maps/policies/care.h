#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "maps/policies/policy.h"

// Task attention over state encoders, after CARE (Sodhani, Zhang, Pineau, ICML 2021; docs/zoo.md), as a
// behaviour-cloning policy. A task context z = MLP(e_k) from a learned task embedding e_k (CARE's is a frozen
// language model's embedding of the task's description, not available here); k encoders E_j(s) of the state; their
// mixture z_enc = sum_j alpha_j E_j(s); and an actor MLP on [z, z_enc]. The attention is CARE's paper's,
// alpha = softmax_j <E_j(s), stopgrad(z)> ("dot", state and task), or its public code's,
// alpha = softmax(MLP(e_k) / temperature) ("task", the task alone).
// Parameters: "task_embedding" [K, C], "context.layers.<i>", "encoders.<l>" (ParallelLinear [k, in, E]),
// "attention.layers.<i>" ("task" only), "actor.layers.<i>".
namespace maps::core {

struct CAREConfig {
  std::int64_t encoders = 6;        // k (the paper's MT10 setting)
  std::int64_t encoder_width = 50;  // each encoder: S -> 50 -> 50 (ReLU between)
  std::int64_t context_width = 50;  // the embedding and the context MLP's 2 layers
  std::int64_t layers = 3;          // the actor's hidden layers
  std::int64_t width = 400;         // the actor's width
  std::string attention = "dot";    // or "task"
  double temperature = 1.0;         // "task" only
};

class CARE : public Policy {
 public:
  CARE(PolicyShape shape, const CAREConfig& config, ag::Generator& gen);

  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  LossTerms loss(const Batch& batch) override;
  // The attention alpha [n, k] of each row.
  ag::Tensor routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  std::int64_t routed_modules() const override { return config_.encoders; }

  const CAREConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<CARE>(*this); }

 private:
  struct Forward {
    ag::Tensor actions;    // [n, A]
    ag::Tensor attention;  // [n, k]
  };
  Forward run(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks);

  CAREConfig config_;
  std::size_t embedding_ = 0, context_ = 0, encoders_ = 0, attention_ = 0, actor_ = 0;
};

double care_parameter_count(const PolicyShape& shape, const CAREConfig& config);

}  // namespace maps::core
