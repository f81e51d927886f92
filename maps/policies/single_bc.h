#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy.h"
#include "nn/activation.h"

namespace maps::core {

// Single BC (PAPER.md, "Baselines"): one MLP S -> 128 -> 128 -> 128 -> A per task, each trained on its own task.
//
// The K MLPs are one module: a chain of nn::ParallelLinear(K, ...) whose member k is task k's network, so a
// balanced batch trains every task in one batched GEMM per layer. loss() is the mean of the K per-task losses,
// and one Adam steps all of them. That equals K independent runs: task k's parameters get gradient from task k's
// rows only (scaled by 1/K), Adam works elementwise, and its update is invariant to a constant gradient scale
// except through eps (1e-8, far below the gradients' RMS). Parameters: "layers.<i>.weight" [K, in, out],
// "layers.<i>.bias" [K, 1, out].
class SingleBC : public Policy {
 public:
  SingleBC(PolicyShape shape, ag::Generator& gen,
           const std::vector<std::int64_t>& hidden_sizes = detail::default_hidden_sizes(),
           nn::Activation activation = nn::Activation::Tanh);

  // Row j from task tasks[j]'s network. The rows are regrouped by task into [K, m, S] (m: the most rows any task
  // has; shorter groups padded with a copy of a row, whose outputs are dropped), so each row goes through its own
  // network only: about the work of one network when the tasks are balanced, never more than K times it.
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  // predict(): PPO's balanced minibatches (GAIL) then run each network on its own task's rows only.
  PolicyForward forward_terms(const Batch& batch) override;
  // Mean over batch and action dims of the squared error; terms {"bc"}. Any batch; balanced ones run faster.
  LossTerms loss(const Batch& batch) override;

  // The actions for a batch's rows: a balanced batch is reshaped to [K, per_task, S] so each network sees only
  // its own task's rows; any other batch goes through act().
  ag::Tensor predict(const Batch& batch);
  // Every network's actions [K, n, A] for the same observations [n, S].
  ag::Tensor forward_all(const ag::Tensor& observations);

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<SingleBC>(*this); }

 private:
  // [K, b, S] or [b, S] -> [K, b, A].
  ag::Tensor run(const ag::Tensor& x);

  nn::Activation activation_;
  std::size_t layers_ = 0;
};

}  // namespace maps::core
