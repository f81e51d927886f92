#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "maps/policies/baseline_util.h"
#include "maps/policies/policy.h"
#include "nn/activation.h"

namespace maps::core {

struct MAMLConfig {
  double inner_lr = 0.01;  // inner-loop and fine-tuning SGD step size
  int inner_steps = 1;     // SGD steps on the support rows per meta-training task
  bool first_order = false;
  std::int64_t query_per_task = 160;  // the paper's meta-batch (PAPER.md: 160 for the cheetah sets, 40 for MT10)
  int finetune_steps = 10;            // the most SGD steps prepare_for_evaluation takes per task
  std::uint64_t finetune_seed = 0;    // draws the fine-tuning training batches in prepare_for_evaluation
  // What chooses the checkpoint: "unadapted": the validation error of theta itself; "adapted": of the fine-tuned
  // policies that are evaluated (prepare_for_evaluation at every validation, then cleared).
  std::string validate = "unadapted";
};

// MAML (PAPER.md, "Baselines"): the policy MLP S -> 128 -> 128 -> 128 -> A on the state only, meta-trained with
// the BC loss: per task, theta'_k = theta - inner_lr * grad L_support_k(theta) (inner_steps times), and the
// outer loss is the mean over tasks of L_query_k(theta'_k), differentiated through the inner step (second
// order) unless first_order. Before evaluation each task fine-tunes theta with up to finetune_steps SGD steps
// and act() then uses each row's task's adapted parameters. Parameters: "policy.layers.<i>.weight/bias".
//
// The adapted parameters are evaluation state, not parameters: they are not in state_dict(), clone() shares
// them, and training theta further leaves them stale (call adapt() again, or clear_adaptation()).
class MAML : public Policy {
 public:
  MAML(PolicyShape shape, ag::Generator& gen, const MAMLConfig& config = {},
       const std::vector<std::int64_t>& hidden_sizes = detail::default_hidden_sizes(),
       nn::Activation activation = nn::Activation::Tanh);

  // Row j from task tasks[j]'s adapted parameters when adapted (rows grouped by task, one forward per task
  // present), else from theta.
  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  // The meta-loss of a balanced batch whose task blocks hold support rows first, then query_per_task query
  // rows. total = mean over tasks of the query loss after adaptation; terms {"query_bc", "support_bc"}, the
  // latter the pre-adaptation support loss (detached: for logs only).
  LossTerms loss(const Batch& batch) override;
  // states_per_task support rows plus query_per_task query rows (and remembers states_per_task as the
  // fine-tuning batch size).
  std::int64_t batch_per_task(std::int64_t states_per_task) const override;
  // Fine-tunes on every task: a training batch of the support size per task (the whole task's training set when
  // no support size is known yet), the task's validation demos to choose the step count; see adapt().
  void prepare_for_evaluation(const DemoDataset& data) override;
  // With validate "adapted": the validation error after prepare_for_evaluation(data), the adaptation then cleared
  // (training goes on from theta). Otherwise the base rule.
  double validation_loss(const Batch& validation, const DemoDataset& data) override;

  // For each task k: up to finetune_steps plain SGD steps (lr inner_lr) from theta on train_per_task[k], keeping
  // the step count in 0..finetune_steps with the lowest loss on valid_per_task[k] (the fewest steps on ties; all
  // finetune_steps when the validation batch is empty). Each batch must hold only its task's rows.
  void adapt(const std::vector<Batch>& train_per_task, const std::vector<Batch>& valid_per_task);
  bool adapted() const { return !adapted_.empty(); }
  void clear_adaptation();
  // After adapt(), per task: the chosen step count and the validation loss before and after it (NaN when the
  // validation batch was empty).
  const std::vector<int>& adapted_steps() const { return adapted_steps_; }
  const std::vector<double>& unadapted_validation_loss() const { return unadapted_validation_loss_; }
  const std::vector<double>& adapted_validation_loss() const { return adapted_validation_loss_; }

  // Plain BC loss of act() on any batch (theta, or the adapted parameters once adapted): a validation metric.
  ag::Tensor bc_loss(const Batch& batch);

  const MAMLConfig& config() const { return config_; }
  // The support rows per task of the last batch_per_task() or loss() call (0 before either).
  std::int64_t support_per_task() const { return support_per_task_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<MAML>(*this); }

 private:
  MAMLConfig config_;
  std::size_t policy_ = 0;
  // Per task, the adapted values of the policy MLP's parameters (in named_parameters() order), detached.
  std::vector<std::vector<ag::Tensor>> adapted_;
  std::vector<int> adapted_steps_;
  std::vector<double> unadapted_validation_loss_;
  std::vector<double> adapted_validation_loss_;
  // batch_per_task() is const in Policy but must remember what it was asked for.
  mutable std::int64_t support_per_task_ = 0;
};

}  // namespace maps::core
