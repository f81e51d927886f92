// A selector loss: the mean overlap of two tasks' module usage, over every pair of tasks in the batch. A task's
// usage is its states' mean selector scores (a point of the simplex over the M modules); the overlap of two is their
// dot product, 1 when both put everything on one module, 0 when they use disjoint modules. Weighted positive it
// divides the modules among the tasks; weighted negative it pushes tasks to share (as the paper's "share" does).
#include <cstdint>
#include <memory>
#include <vector>

#include "maps/selector/selector_loss.h"

namespace {

namespace ag = maps::ag;
using maps::core::SelectorLoss;
using maps::core::SelectorOutputs;

class TaskOverlapLoss : public SelectorLoss {
 public:
  TaskOverlapLoss() : SelectorLoss("TaskOverlapLoss") {}
  std::string name() const override { return "task_overlap"; }
  ag::Tensor forward(const SelectorOutputs& out) override {
    std::vector<ag::Tensor> usages;  // [M] per task present in the batch
    for (std::int64_t k = 0; k < out.num_tasks; ++k) {
      std::vector<std::int64_t> rows;
      for (std::size_t i = 0; i < out.tasks.size(); ++i)
        if (out.tasks[i] == k) rows.push_back(static_cast<std::int64_t>(i));
      if (!rows.empty()) usages.push_back(ag::mean(ag::index_select(out.scores, rows), {0}));
    }
    const double tasks = static_cast<double>(usages.size());
    if (usages.size() < 2) return ag::sum(out.scores) * 0.0;                    // no pair: nothing to divide
    const ag::Tensor usage = ag::stack(usages, 0);                              // [K, M]
    const ag::Tensor overlaps = ag::matmul(usage, ag::transpose(usage, 0, 1));  // [K, K]
    const ag::Tensor between = ag::sum(overlaps) - ag::sum(ag::square(usage));  // off the diagonal
    return between / (tasks * (tasks - 1.0));
  }

 protected:
  std::shared_ptr<maps::nn::Module> shallow_copy() const override { return std::make_shared<TaskOverlapLoss>(*this); }
};

}  // namespace

MAPS_REGISTER_SELECTOR_LOSS("task_overlap", [] { return std::make_shared<TaskOverlapLoss>(); });
