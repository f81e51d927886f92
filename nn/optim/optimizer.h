#pragma once

#include <vector>

#include "autograd/autograd.h"

namespace maps::optim {

// Base of the optimisers, after torch::optim::Optimizer (one parameter group). Holds handles to the
// parameters (leaves); step() updates their values in place under a NoGradGuard from their grad(), skipping
// parameters whose grad is undefined. Per-parameter state is kept by position in params().
class Optimizer {
 public:
  explicit Optimizer(std::vector<ag::Tensor> params, const char* name);
  virtual ~Optimizer() = default;
  Optimizer(const Optimizer&) = delete;
  Optimizer& operator=(const Optimizer&) = delete;

  virtual void step() = 0;
  // Sets every parameter's grad to undefined (set_to_none, LibTorch's default).
  void zero_grad();

  virtual double lr() const = 0;
  // For schedules (annealing); must be >= 0.
  virtual void set_lr(double lr) = 0;

  const std::vector<ag::Tensor>& params() const { return params_; }

 protected:
  // The grad of params_[i] if it has one that matches the parameter's shape and dtype; undefined when it has
  // none; throws naming the optimiser and the parameter index when it mismatches.
  ag::Tensor checked_grad(std::size_t i) const;
  const char* name_;
  std::vector<ag::Tensor> params_;
};

}  // namespace maps::optim
