// share: states should get the same module scores whatever the task, so that tasks share modules.
//   L_share = mean over states s, modules i and ordered task pairs k1 != k2 of (g_i(s,k1) - g_i(s,k2))^2.

#include "maps/selector/selector_loss.h"

namespace maps::core {
namespace {

class ShareLoss : public SelectorLoss {
 public:
  ShareLoss() : SelectorLoss("ShareLoss") {}
  std::string name() const override { return "share"; }

  ag::Tensor forward(const SelectorOutputs& out) override {
    const ag::Tensor& a = out.all_task_scores;  // [K, b, M]
    const double K = static_cast<double>(a.size(0));
    if (a.size(0) < 2) return ag::zeros({}, a.dtype());  // one task: nothing to share between
    // Summed over all ordered pairs (the k1 == k2 terms are 0): sum_{k1,k2} (a1 - a2)^2 = 2K sum a^2 - 2 (sum_k a)^2,
    // one pass over the scores instead of K^2.
    const ag::Tensor pair_sum = 2.0 * K * ag::sum(ag::square(a)) - 2.0 * ag::sum(ag::square(ag::sum(a, {0})));
    const double count = K * (K - 1.0) * static_cast<double>(a.size(1) * a.size(2));
    return pair_sum / count;
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ShareLoss>(*this); }
};

}  // namespace

std::shared_ptr<SelectorLoss> make_share_loss() { return std::make_shared<ShareLoss>(); }

}  // namespace maps::core
