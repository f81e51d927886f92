#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy.h"
#include "nn/activation.h"

namespace maps::core {

// MT-BC (PAPER.md, "Baselines"): one MLP (S + K) -> 128 -> 128 -> 128 -> A on [s, onehot(k)], shared by every
// task. Parameters: "mlp.layers.<i>.weight", "mlp.layers.<i>.bias".
class MTBC : public Policy {
 public:
  MTBC(PolicyShape shape, ag::Generator& gen,
       const std::vector<std::int64_t>& hidden_sizes = detail::default_hidden_sizes(),
       nn::Activation activation = nn::Activation::Tanh);

  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  // Mean over batch and action dims of the squared error; terms {"bc"}. Any batch (balanced or not).
  LossTerms loss(const Batch& batch) override;

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<MTBC>(*this); }

 private:
  ag::Tensor forward(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks);

  std::size_t mlp_ = 0;
};

}  // namespace maps::core
