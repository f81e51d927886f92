#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "maps/policies/policy.h"
#include "nn/module_list.h"

// A sparsely-gated mixture of experts (Shazeer et al., ICLR 2017; docs/zoo.md) as a behaviour-cloning policy. On
// x = [s, one_hot(k)], the gate's logits H(x) = x W_g + eps * (softplus(x W_noise) + 0.01), eps ~ N(0, 1) in training
// only; G(x) = softmax over the top k of H(x) (the others 0); the action sum_i G_i(x) E_i(x), where only the chosen
// experts run (each on the rows that chose it). Experts are MLPs x -> width^layers -> A (ReLU). Such gates can
// collapse onto a few experts (Shazeer et al.), so the loss adds balance * (CV^2(importance) + CV^2(load)): importance
// the batch's sum of G per expert, load the batch's sum of each expert's smooth probability of staying in the top k
// under fresh noise. top_k is at least 2: with one expert chosen its softmax weight is 1 whatever the logits, and the
// gate would learn nothing from the BC loss (Shazeer et al. need k > 1 for the gate's gradient).
// Parameters: "experts.<i>.layers.<l>", "gate_weight" [S + K, E], "noise_weight" [S + K, E] (both start at 0).
namespace maps::core {

struct TopKMoEConfig {
  std::int64_t experts = 4;
  std::int64_t top_k = 2;
  std::int64_t layers = 3;
  std::int64_t width = 400;
  double balance = 0.01;  // the weight of the importance and load losses (the reference port's)
  bool noise = true;      // noisy gating in training
};

class TopKMoE : public Policy {
 public:
  TopKMoE(PolicyShape shape, const TopKMoEConfig& config, ag::Generator& gen);

  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  // terms {"bc", "importance", "load"}; total = bc + balance * (importance + load).
  LossTerms loss(const Batch& batch) override;
  // Under PPO (GAIL): the mean actions as act() gives them (the noiseless gate: the rollouts' log-probabilities were
  // taken there), and the balance terms {"importance", "load"} weighted as loss() weighs them, importance on that
  // gate and load on the batch's noisy gate (it is the noise's probability; without noise, 0).
  PolicyForward forward_terms(const Batch& batch) override;
  // The gate G [n, E] without noise (what act() uses).
  ag::Tensor routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  std::int64_t routed_modules() const override { return config_.experts; }

  const TopKMoEConfig& config() const { return config_; }

  // The standard normal draws eps [rows, experts] of the noisy gate for a batch with this noise seed (so that a
  // test can recompute the gate, its importance and its load by hand).
  static ag::Tensor gate_noise(std::int64_t rows, std::int64_t experts, std::uint64_t noise_seed, ag::Dtype dtype);

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<TopKMoE>(*this); }

 private:
  struct Gate {
    ag::Tensor gates;                  // [n, E], zero outside each row's top k
    std::vector<std::int64_t> chosen;  // [n * k]: each row's experts, best first
    ag::Tensor load;                   // [E] (training with noise only)
  };
  Gate gate(const ag::Tensor& inputs, const std::uint64_t* noise_seed);
  ag::Tensor mixture(const ag::Tensor& inputs, const Gate& g);

  TopKMoEConfig config_;
  std::size_t experts_ = 0, gate_weight_ = 0, noise_weight_ = 0;
};

double top_k_moe_parameter_count(const PolicyShape& shape, const TopKMoEConfig& config);

// sum over each row's k chosen experts (`chosen` [n k], row-major) of its gate ([n, E]) times the expert (an nn::MLP
// of `experts`) on the row: each expert runs once, on the rows that chose it (index_select in, index_add out); an
// expert no row chose does not run. [n, out].
ag::Tensor gated_expert_sum(const nn::ModuleList& experts, const ag::Tensor& inputs,
                            const std::vector<std::int64_t>& chosen, const ag::Tensor& gates, std::int64_t k);

}  // namespace maps::core
