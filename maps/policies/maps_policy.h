#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "maps/policies/policy.h"
#include "maps/selector/selector_loss.h"
#include "nn/activation.h"
#include "nn/mlp.h"
#include "nn/parallel_linear.h"

// MAPS (PAPER.md, Model): M proto-policy modules mu_i(s) see the state only; a selector G(s, k) scores them with a
// softmax; a head maps the scored features concat(g_1 v_1, ..., g_M v_M) to the action.
namespace maps::core {

struct MAPSConfig {
  std::int64_t modules = 10;                                  // M
  std::vector<std::int64_t> module_hidden = {128, 128, 128};  // each module: S -> ... -> features (the last)
  std::vector<std::int64_t> selector_hidden = {128, 128};     // [S + K] -> ... -> M
  std::string activation = "tanh";                            // after every module layer and in the selector's hidden
  double bc_weight = 0.75;
  double selector_weight = 0.25;
  // Selector losses and their weights (lambda); the paper's HalfCheetah values by default.
  std::vector<std::pair<std::string, double>> selector_losses = {
      {"share", 1.0}, {"explore", 0.5}, {"sparse", 0.001}, {"smooth", 1.0}};
  // "learned": G(s, k) as above. "uniform": every score 1/M, no selector and no selector losses: the control that
  // asks whether MAPS is more than an average of M modules (its modules and head start as the learned model's of
  // the same seed; the selector is MAPS's only input of the task, so this policy does not see the task). "task": G(k),
  // the selector with its state input zeroed, so each task has one fixed mixture of modules whatever the state (the
  // control that asks whether the routing needs the state or only the task; the first layer keeps its state columns,
  // unused, so its parameters are named and shaped as the learned selector's).
  std::string selector = "learned";
  // "standardized": modules and selector see the standardised observations. "raw_clipped": the paper's code's
  // inputs: the modules see the raw observations clipped to [-5, 5], the selector the raw ones (recovered from the
  // standardised input with the statistics set_observation_statistics gave, kept as buffers).
  std::string observations = "standardized";
};

// MAPS's head, Linear(M F -> out) over the concatenated scored features kept as M blocks [F, out] without bias, and
// its bias [out]; both uniform in +-1/sqrt(M F) (PyTorch's bound for fan_in M F), drawn in that order.
struct ScoredHead {
  std::shared_ptr<nn::ParallelLinear> blocks;
  ag::Tensor bias;
};
ScoredHead make_scored_head(std::int64_t modules, std::int64_t features, std::int64_t outputs, ag::Generator& gen);

// The kinds MAPSConfig::selector takes, and their list as error messages quote it.
inline constexpr const char* kSelectorKinds = "\"learned\", \"uniform\" or \"task\"";
bool is_selector_kind(const std::string& kind);

class MAPSPolicy : public Policy {
 public:
  MAPSPolicy(PolicyShape shape, const MAPSConfig& config, ag::Generator& gen);

  ag::Tensor act(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override;
  // total = bc_weight * L_BC + selector_weight * sum_j lambda_j L_j; terms: "bc", then each selector loss by name.
  LossTerms loss(const Batch& batch) override;
  // The head's actions and the selector losses (total: selector_weight * sum_j lambda_j L_j).
  PolicyForward forward_terms(const Batch& batch) override;

  // The selector's scores (scores()).
  ag::Tensor routing(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks) override {
    return scores(observations, tasks);
  }
  std::int64_t routed_modules() const override { return config_.modules; }

  // Module features [M, n, F] of standardised observations [n, S].
  ag::Tensor features(const ag::Tensor& observations);
  // Selector scores g(s, k) [n, M] (softmax over modules) of each observation under its task.
  ag::Tensor scores(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks);
  // The action from module features [M, n, F] and scores [n, M].
  ag::Tensor head(const ag::Tensor& features, const ag::Tensor& scores);

  const MAPSConfig& config() const { return config_; }
  std::int64_t num_modules() const { return config_.modules; }
  bool uniform_selector() const { return config_.selector == "uniform"; }
  bool task_selector() const { return config_.selector == "task"; }
  bool raw_inputs() const { return config_.observations == "raw_clipped"; }
  void set_observation_statistics(const Eigen::VectorXd& mean, const Eigen::VectorXd& std) override;

  // Puts every score of act() and scores() on module `module` (-1: the selector's own scores again), the paper's
  // Fig. 6 probe of what one module does alone. The loss is unaffected; this is not saved with the state.
  void force_module(std::int64_t module);
  std::int64_t forced_module() const { return forced_module_; }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<MAPSPolicy>(*this); }

 private:
  // scores() for inputs the caller has already checked (act and loss check theirs once, up front).
  ag::Tensor checked_scores(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks);
  // checked_scores, or the forced module's one-hot rows.
  ag::Tensor evaluation_scores(const ag::Tensor& observations, const std::vector<std::int64_t>& tasks);
  // The selector's first layer is linear in [s, one_hot(k)]: W [s; e_k] + b = W_s s + (W_k + b). state_weight is
  // W_s [H, S]; task_rows [K, H] holds W_k + b for each task.
  struct SelectorFirstLayer {
    ag::Tensor state_weight;
    ag::Tensor task_rows;
  };
  SelectorFirstLayer selector_first_layer();
  // The selector's logits for rows whose first layer is state_parts[state_rows[i]] + task_rows[tasks[i]].
  ag::Tensor selector_logits(const ag::Tensor& state_parts, const std::vector<std::int64_t>& state_rows,
                             const ag::Tensor& task_rows, const std::vector<std::int64_t>& tasks);

  // What the modules and the selector see of standardised observations [n, S] (the identity but for raw_clipped).
  ag::Tensor module_inputs(const ag::Tensor& observations) const;
  ag::Tensor selector_inputs(const ag::Tensor& observations) const;
  // W_s s [n, H] for the selector's first layer, or zeros for the task-only selector.
  ag::Tensor selector_state_parts(const ag::Tensor& observations, const ag::Tensor& state_weight) const;

  MAPSConfig config_;
  nn::Activation activation_;
  std::size_t observation_mean_ = 0, observation_std_ = 0;  // buffer slots (raw_clipped only)
  std::vector<std::size_t> module_layers_;                  // child slots of the ParallelLinear layers
  std::size_t selector_ = 0;                                // child slot of the selector MLP
  std::size_t head_weight_ = 0;                             // child slot of the head's ParallelLinear (no bias)
  std::size_t head_bias_ = 0;                               // parameter slot [A]
  std::vector<std::size_t> losses_;                         // child slots of the selector losses
  std::vector<double> loss_weights_;
  std::int64_t forced_module_ = -1;
};

}  // namespace maps::core
