#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy.h"
#include "nn/activation.h"

namespace maps::core {

// MT-MH-BC (PAPER.md, "Baselines"): a trunk MLP S -> 128 -> 128 -> 128 on the state (activation after every
// layer, like a MAPS module) and one Linear head 128 -> A per task; task k uses head k. The heads are one
// nn::ParallelLinear(K, 128, A). Parameters: "trunk.layers.<i>.weight/bias", "heads.weight" [K, 128, A],
// "heads.bias" [K, 1, A].
class MTMHBC : public Policy {
 public:
  MTMHBC(PolicyShape shape, ag::Generator& gen,
         const std::vector<std::int64_t>& hidden_sizes = detail::default_hidden_sizes(),
         nn::Activation activation = nn::Activation::Tanh);

  // Row j from head tasks[j]. Every head sees every row (one batched GEMM) and each row keeps its own head's.
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  // Mean over batch and action dims of the squared error; terms {"bc"}. Any batch; balanced ones run faster.
  LossTerms loss(const Batch& batch) override;

  // The actions for a batch's rows: for a balanced batch head k sees only task k's rows; otherwise as act().
  ag::Tensor predict(const Batch& batch);

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<MTMHBC>(*this); }

 private:
  std::size_t trunk_ = 0;
  std::size_t heads_ = 0;
};

}  // namespace maps::core
