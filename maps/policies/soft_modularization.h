#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "maps/policies/policy.h"

// Soft Modularization (Yang, Xu, Wu, Wang, NeurIPS 2020; docs/zoo.md) as a behaviour-cloning policy, after the
// official code's ModularGatedCascadeCondNet:
//   f = base(s) (MLP, ReLU between, none after), e = Linear(one_hot(k)); g0 = ReLU(f * e); g = gating MLP(g0).
//   p^1 = softmax_rows(W_d^1 ReLU(g)) (n x n); p^l = softmax_rows(W_d^l ReLU(W_u^l [p^1 ... p^(l-1)] * g));
//   a = softmax(W_last ReLU(W_u^last [p^1 ... p^(L-1)] * g)) (n).
//   x^1_j = M^1_j(ReLU(f)); x^(l+1)_i = M^(l+1)_i(ReLU(sum_j p^l_ij x^l_j)); action = Linear(ReLU(sum_j a_j x^L_j)).
// Each module M is one Linear of module width. "aggregation" chooses the last sum: "softmax" (the official code's
// a), "sum" (the paper's Eq. 9, unweighted) or "mean" (mtrl's).
namespace maps::core {

struct SoftModularizationConfig {
  std::int64_t module_layers = 2;   // L (the paper's "Shallow" MT10 setting; "Deep": 4)
  std::int64_t modules = 2;         // n per layer (Deep: 4)
  std::int64_t module_width = 256;  // (Deep: 128)
  std::int64_t base_width = 400;    // the base MLP's two layers and the task embedding
  std::int64_t gating_width = 256;  // the gating MLP's two layers
  std::string aggregation = "softmax";
  // "official": the official code's initialisation (torchrl/networks/init.py), which starts the routing and the
  // actions near their centres: the routing heads (W_d, W_last) and the output layer U(+-3e-3) for weight and bias;
  // every other layer's weight U(+-1/sqrt(its output width)) (its fan-in helper reads dimension 0 of PyTorch's
  // [out, in] weight) and bias 0.1. "pytorch": every layer as torch.nn.Linear initialises one.
  std::string init = "official";
};

class SoftModularization : public Policy {
 public:
  SoftModularization(PolicyShape shape, const SoftModularizationConfig& config, ag::Generator& gen);

  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  LossTerms loss(const Batch& batch) override;
  // The use of every (layer, module): for the modules of layer l < L the mean over destinations of p^l's weights on
  // them, for layer L the final weights a; each layer's n shares sum to 1, divided by L so a row sums to 1:
  // [n, L * n], layer-major.
  ag::Tensor routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  std::int64_t routed_modules() const override { return config_.module_layers * config_.modules; }

  const SoftModularizationConfig& config() const { return config_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<SoftModularization>(*this); }

 private:
  struct Forward {
    ag::Tensor actions;                     // [n, A]
    std::vector<ag::Tensor> probabilities;  // p^l [n, modules, modules] for l < L, then a [n, modules]
  };
  Forward run(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks);

  SoftModularizationConfig config_;
  std::size_t base_ = 0, embedding_ = 0, gating_ = 0, down_ = 0, up_ = 0, last_ = 0, module_layers_ = 0, output_ = 0;
};

double soft_modularization_parameter_count(const PolicyShape& shape, const SoftModularizationConfig& config);

}  // namespace maps::core
