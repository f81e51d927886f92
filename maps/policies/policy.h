#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "autograd/autograd.h"
#include "maps/chunking/action_chunking.h"
#include "maps/data/batch.h"
#include "nn/module.h"

// The interface every method implements (MAPS and the baselines), so the trainer and the evaluator treat them alike.
namespace maps::core {

// Named loss terms (for logs and curves) and the total the optimiser minimises.
struct LossTerms {
  ag::Tensor total;
  std::vector<std::pair<std::string, ag::Tensor>> terms;  // e.g. {"bc", ...}, {"share", ...}
};

// The sizes every policy is built for.
struct PolicyShape {
  std::int64_t observation_size = 0;  // S
  std::int64_t action_size = 0;       // A
  std::int64_t num_tasks = 0;         // K
};

class DemoDataset;

// A batch's mean actions with their graph, and the method's own terms on those states besides imitation.
struct PolicyForward {
  ag::Tensor mean_actions;  // [n, A]
  LossTerms regularizer;    // weighted as the method's loss weighs them; total undefined when there are none
};

class Policy : public nn::Module {
 public:
  Policy(std::string type_name, PolicyShape shape) : nn::Module(std::move(type_name)), shape_(shape) {}

  // Actions [n, A] for standardised observations [n, S] of the given tasks (deterministic: the mean action). A
  // policy predicting chunks (chunking().horizon H > 1) returns [n, H * A]: each row the step's action and the H - 1
  // after it, time-major; shape().action_size is then H * A.
  virtual ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) = 0;
  // What the evaluator calls: act() given the previous states too ([n, S], standardised; the first state itself at
  // an episode's start), which a policy with chunking().previous_observation reads. Default: act(observations).
  virtual ag::Tensor act_with_history(const ag::Tensor& observations, const ag::Tensor& previous_observations,
                                      const std::vector<std::int64_t>& tasks);
  // How its predictions are executed (horizon 1: one action per step, the default).
  const chunking::ActionChunking& chunking() const { return chunking_; }
  // Predict chunks of chunking.horizon actions of action_size each: the policy must have been built for
  // shape().action_size = horizon * action_size (make_policy does both). Throws when the sizes disagree.
  void set_chunking(const chunking::ActionChunking& chunking, std::int64_t action_size);
  // The env's action size (shape().action_size / horizon).
  std::int64_t step_action_size() const { return shape_.action_size / chunking_.horizon; }
  // The loss of one training batch (built for a balanced batch of batch_per_task() rows per task).
  virtual LossTerms loss(const Batch& batch) = 0;
  // For imitation objectives other than BC (GAIL's PPO loss, maps/adversarial/): the mean actions of the batch's
  // states with their graph, and the method's own regularisers on them (MAPS: its selector losses; batch.actions is
  // not used). loss() is a BC term on these means plus the same regularisers. Default: act() and none.
  virtual PolicyForward forward_terms(const Batch& batch);
  // Rows per task a training batch should hold (MAML asks for support + query).
  virtual std::int64_t batch_per_task(std::int64_t states_per_task) const { return states_per_task; }
  // Called by the trainer after each optimiser step (PaCo resets the task weights of the tasks its loss masked).
  virtual void after_step() {}
  // Called once after training, before evaluation (MAML fine-tunes on each task here).
  virtual void prepare_for_evaluation(const DemoDataset& /*data*/) {}
  // The statistics the observations it is given were standardised with (mean, std [S]); called by the trainer
  // before training. A policy that wants the raw observations back (MAPS with observations "raw_clipped") keeps
  // them as buffers, so that its checkpoints carry them.
  virtual void set_observation_statistics(const Eigen::VectorXd& /*mean*/, const Eigen::VectorXd& /*std*/) {}

  // How much each of the policy's modules (experts, parameter sets) weighs in each row's action: [n, M] rows of
  // non-negative shares summing to 1, for the evaluator's module usage per task (and the zoo's task division).
  // Policies without modules return an undefined tensor and routed_modules() 0.
  virtual ag::Tensor routing(const ag::Tensor& /*observations*/, const std::vector<std::int64_t>& /*tasks*/) {
    return {};
  }
  virtual std::int64_t routed_modules() const { return 0; }

  const PolicyShape& shape() const { return shape_; }

  // The paper's code's BC loss (train.bc_loss "sampled"): the squared error of a Gaussian sample
  // mean + exp(log_std) * eps instead of the mean, with a learned state-independent log_std [A] (parameter
  // "log_std", starting at 0). Its expectation is the mean's squared error plus exp(2 log_std), so log_std falls
  // through training and the noise on the mean's gradient anneals itself. Call before training or loading.
  void use_sampled_bc_loss();
  bool sampled_bc_loss() const { return log_std_slot_ >= 0; }

  // The loss that chooses the checkpoint: the mean squared error of act() on the validation rows. `data` is the
  // run's dataset, for a policy that must adapt first (MAML with validate "adapted").
  virtual double validation_loss(const Batch& validation, const DemoDataset& data);

 protected:
  Policy(const Policy&) = default;

  // BC loss of the predicted mean actions [n, A] against batch.actions: their squared error, or with
  // use_sampled_bc_loss() that of a sample whose noise comes from batch.noise_seed.
  ag::Tensor bc_loss(const ag::Tensor& mean_actions, const Batch& batch) const;

 private:
  PolicyShape shape_;
  chunking::ActionChunking chunking_;
  std::int64_t log_std_slot_ = -1;
};

// The mean squared error of policy.act() on a batch, in chunks, without gradients.
double mean_action_error(Policy& policy, const Batch& batch);

// Rows j of a [K * n, ...] tensor holding every task's output for n inputs, task-major: row tasks[j] * n + j.
std::vector<std::int64_t> own_task_rows(const std::vector<std::int64_t>& tasks);

}  // namespace maps::core
