// A selector loss written outside maps/selector/: docs/selector-losses.md shows this file whole (a test checks that
// the page and the file agree), and selector_registry_test.cpp trains nothing with it but checks its value.
#include <memory>
#include <vector>

#include "maps/selector/selector_loss.h"

namespace {

using maps::ag::Tensor;
using maps::core::SelectorLoss;
using maps::core::SelectorOutputs;

// Minus the mean over tasks of the entropy of each task's usage (its states' mean scores over the modules): it
// spreads each task over the modules it uses. 0 at most, -log M at least.
class TaskEntropyLoss : public SelectorLoss {
 public:
  TaskEntropyLoss() : SelectorLoss("TaskEntropyLoss") {}
  std::string name() const override { return "task_entropy"; }
  Tensor forward(const SelectorOutputs& out) override {
    Tensor total;
    int tasks_seen = 0;
    for (std::int64_t k = 0; k < out.num_tasks; ++k) {
      std::vector<std::int64_t> rows;  // the batch's states of task k
      for (std::size_t i = 0; i < out.tasks.size(); ++i)
        if (out.tasks[i] == k) rows.push_back(static_cast<std::int64_t>(i));
      if (rows.empty()) continue;
      const Tensor usage = maps::ag::mean(maps::ag::index_select(out.scores, rows), {0});  // [M]
      const Tensor negative_entropy = maps::ag::sum(usage * maps::ag::log(maps::ag::clamp_min(usage, 1e-30)));
      total = tasks_seen++ == 0 ? negative_entropy : total + negative_entropy;
    }
    return total / static_cast<double>(tasks_seen);
  }

 protected:
  std::shared_ptr<maps::nn::Module> shallow_copy() const override { return std::make_shared<TaskEntropyLoss>(*this); }
};

MAPS_REGISTER_SELECTOR_LOSS("task_entropy", [] { return std::make_shared<TaskEntropyLoss>(); });

}  // namespace
