// smooth: consecutive states of a demonstration should get similar scores, so the policy does not switch modules
// from step to step.
//   L_smooth = (1/(M b)) sum_{s,i} (g_i(s_t, k) - g_i(s_{t-1}, k))^2.

#include "maps/selector/selector_loss.h"

namespace maps::core {
namespace {

class SmoothLoss : public SelectorLoss {
 public:
  SmoothLoss() : SelectorLoss("SmoothLoss") {}
  std::string name() const override { return "smooth"; }

  ag::Tensor forward(const SelectorOutputs& out) override {
    const ag::Tensor& g = out.scores;  // [b, M]
    return ag::mean(ag::square(g - out.previous_scores));
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<SmoothLoss>(*this); }
};

}  // namespace

std::shared_ptr<SelectorLoss> make_smooth_loss() { return std::make_shared<SmoothLoss>(); }

}  // namespace maps::core
