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
    // Summed over all ordered pairs (the k1 == k2 terms are 0): sum_{k1,k2} (a1 - a2)^2 = 2K sum_k (d_k - mean_k d)^2
    // for d_k = a_k - a_0, one pass over the scores instead of K^2. The equal 2K sum a^2 - 2 (sum_k a)^2 cancels where
    // training drives it (tasks agreeing): negative values and no correct digits below ~1e-8 in float32. Squares
    // cannot be negative; d_k is exact for scores within a factor 2 of each other (Sterbenz), so the deviations
    // keep their digits however close the tasks are, and tasks that agree exactly give exactly 0.
    const ag::Tensor d = a - ag::narrow(a, 0, 0, 1);
    const ag::Tensor deviations = d - ag::mean(d, {0}, /*keepdim=*/true);
    const ag::Tensor pair_sum = 2.0 * K * ag::sum(ag::square(deviations));
    const double count = K * (K - 1.0) * static_cast<double>(a.size(1) * a.size(2));
    return pair_sum / count;
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ShareLoss>(*this); }
};

}  // namespace

std::shared_ptr<SelectorLoss> make_share_loss() { return std::make_shared<ShareLoss>(); }

}  // namespace maps::core
