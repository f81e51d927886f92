// explore: every module should be used about equally over the batch, so that none is left idle.
//   L_explore = (M / b^2) sum_i (b/M - sum_s g_i(s, k_s))^2, the squared coefficient of variation of the modules'
//   usage (their summed scores).

#include "maps/selector/selector_loss.h"

namespace maps::core {
namespace {

class ExploreLoss : public SelectorLoss {
 public:
  ExploreLoss() : SelectorLoss("ExploreLoss") {}
  std::string name() const override { return "explore"; }

  ag::Tensor forward(const SelectorOutputs& out) override {
    const ag::Tensor& g = out.scores;  // [b, M]
    const double b = static_cast<double>(g.size(0)), M = static_cast<double>(g.size(1));
    const ag::Tensor usage = ag::sum(g, {0});  // [M]
    return ag::sum(ag::square(usage - b / M)) * (M / (b * b));
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<ExploreLoss>(*this); }
};

}  // namespace

std::shared_ptr<SelectorLoss> make_explore_loss() { return std::make_shared<ExploreLoss>(); }

}  // namespace maps::core
