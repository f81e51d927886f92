#pragma once

#include <cstdint>
#include <vector>

#include "nn/module.h"
#include "nn/optim/optimizer.h"

namespace maps::optim {

// torch::optim::AdamOptions. Designated initialisers read well: Adam(params, {.lr = 3e-4, .eps = 1e-5}).
struct AdamOptions {
  double lr = 1e-3;
  double beta1 = 0.9;
  double beta2 = 0.999;
  double eps = 1e-8;
  double weight_decay = 0.0;  // L2, coupled (added to the gradient), as torch's Adam; not AdamW
};

// torch::optim::Adam's update, step t = 1, 2, ... per parameter:
//   g <- g + weight_decay * p
//   m <- beta1 m + (1 - beta1) g
//   v <- beta2 v + (1 - beta2) g^2
//   p <- p - lr / (1 - beta1^t) * m / (sqrt(v) / sqrt(1 - beta2^t) + eps)
// Parameters without a grad are skipped (their step count does not advance). Options out of range throw.
class Adam : public Optimizer {
 public:
  Adam(std::vector<ag::Tensor> params, const AdamOptions& options = {});

  void step() override;
  double lr() const override { return options_.lr; }
  void set_lr(double lr) override;
  const AdamOptions& options() const { return options_; }

  // Parameter i's learning rate is lr() times this factor (1 unless set; e.g. modules fine-tuned slower than a new
  // task's selector row in transfer).
  void set_lr_scale(std::size_t i, double scale);
  double lr_scale(std::size_t i) const { return lr_scales_.at(i); }

  // Number of steps taken by parameter i (0 before its first update).
  std::int64_t step_count(std::size_t i) const { return state_.at(i).step; }

  // The moments and step counts, for checkpoints: "step.<i>" (float64 scalar), "exp_avg.<i>", "exp_avg_sq.<i>"
  // for every parameter i that has taken a step. load_state() checks every name, shape and dtype against the
  // parameters and throws naming the first mismatch, leaving the state unchanged.
  nn::NamedTensors state() const;
  void load_state(const nn::NamedTensors& state);

 private:
  struct State {
    std::int64_t step = 0;
    ag::Tensor exp_avg;     // m
    ag::Tensor exp_avg_sq;  // v
  };
  AdamOptions options_;
  std::vector<State> state_;
  std::vector<double> lr_scales_;
};

}  // namespace maps::optim
