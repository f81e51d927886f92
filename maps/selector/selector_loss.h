#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "nn/module.h"

// Losses on MAPS's selector scores (PAPER.md, Losses). Each is an nn module behind one small interface: a name
// and a function of the selector's outputs for the batch; MAPS weighs them as the config says. Adding one is one
// new file defining the class and its make_ function, and one line in selector_registry.cpp (docs/selector-losses.md).
namespace maps::core {

// The selector's softmax scores for one batch of b states of K tasks over M modules.
struct SelectorOutputs {
  ag::Tensor scores;                // [b, M]: g(s, k_s), each state under its own task
  ag::Tensor all_task_scores;       // [K, b, M]: g(s, k) for every task k
  ag::Tensor previous_scores;       // [b, M]: g(s_prev, k_s), the state before each one in its demonstration
  std::vector<std::int64_t> tasks;  // [b]: k_s
  std::int64_t num_tasks = 0;       // K
  std::int64_t num_modules = 0;     // M
};

class SelectorLoss : public nn::Module {
 public:
  using nn::Module::Module;
  // The loss's name in configs and logs ("share").
  virtual std::string name() const = 0;
  // A scalar (shape {}) in the scores' dtype, differentiable in the scores.
  virtual ag::Tensor forward(const SelectorOutputs& outputs) = 0;
};

using SelectorLossFactory = std::function<std::shared_ptr<SelectorLoss>()>;

struct SelectorLossEntry {
  std::string name;
  SelectorLossFactory make;
};

// Every known selector loss, in the order configs and logs list them.
const std::vector<SelectorLossEntry>& selector_losses();
// A new loss by name; an unknown name is an error listing the known ones.
std::shared_ptr<SelectorLoss> make_selector_loss(const std::string& name);

// The losses of the paper (one file each).
std::shared_ptr<SelectorLoss> make_share_loss();
std::shared_ptr<SelectorLoss> make_explore_loss();
std::shared_ptr<SelectorLoss> make_sparse_loss();
std::shared_ptr<SelectorLoss> make_smooth_loss();

}  // namespace maps::core
