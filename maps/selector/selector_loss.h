#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "autograd/autograd.h"
#include "io/registry.h"
#include "nn/module.h"

// Losses on MAPS's selector scores (PAPER.md, Losses). Each is an nn module behind one small interface: a name
// and a function of the selector's outputs for the batch; MAPS weighs them as the config says. The paper's four are
// built in (selector_registry.cpp); another is registered by name with MAPS_REGISTER_SELECTOR_LOSS, from a file of
// the tree, a program's own or a plugin (docs/selector-losses.md).
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

// Every known selector loss: the built-ins in the order configs and logs list them, then the registered ones.
const std::deque<SelectorLossEntry>& selector_losses();
// A new loss by name; an unknown name is an error listing the known ones.
std::shared_ptr<SelectorLoss> make_selector_loss(const std::string& name);
// "share, explore, sparse, smooth, ...".
std::string selector_loss_names();
// Adds a loss (io::Registry::add: a plain name not taken, else std::invalid_argument naming it and the taker).
void register_selector_loss(const std::string& name, SelectorLossFactory make);
// Where a loss comes from: "" for the built-ins and the program's own, else the plugin's path.
std::string selector_loss_origin(const std::string& name);

// The losses of the paper (one file each).
std::shared_ptr<SelectorLoss> make_share_loss();
std::shared_ptr<SelectorLoss> make_explore_loss();
std::shared_ptr<SelectorLoss> make_sparse_loss();
std::shared_ptr<SelectorLoss> make_smooth_loss();

}  // namespace maps::core

// Registers a selector loss while the program or plugin starts, at namespace scope of one .cpp:
//   MAPS_REGISTER_SELECTOR_LOSS("task_entropy", [] { return std::make_shared<TaskEntropyLoss>(); });
// A refused name (taken, or not plain) is recorded and reported by the plugin loader or the registry's first use.
#define MAPS_REGISTER_SELECTOR_LOSS(NAME, FACTORY) \
  MAPS_REGISTRATION_(::maps::core::register_selector_loss(NAME, FACTORY))
