#pragma once

#include <vector>

#include "nn/optim/optimizer.h"

namespace maps::optim {

// torch::optim::SGDOptions (lr has no sensible default, so it comes first and is required).
struct SGDOptions {
  double lr;
  double momentum = 0.0;
  double dampening = 0.0;
  double weight_decay = 0.0;  // L2, coupled
  bool nesterov = false;      // needs momentum > 0 and dampening == 0
};

// torch::optim::SGD's update:
//   d <- g + weight_decay * p
//   with momentum: buf <- d on the first step, else buf <- momentum buf + (1 - dampening) d;
//                  d <- d + momentum buf (nesterov) or d <- buf
//   p <- p - lr d
// Parameters without a grad are skipped. Options out of range throw.
class SGD : public Optimizer {
 public:
  SGD(std::vector<ag::Tensor> params, const SGDOptions& options);

  void step() override;
  double lr() const override { return options_.lr; }
  void set_lr(double lr) override;
  const SGDOptions& options() const { return options_; }

 private:
  SGDOptions options_;
  std::vector<ag::Tensor> momentum_buffers_;  // undefined until a parameter's first step with momentum
};

}  // namespace maps::optim
