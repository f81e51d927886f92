// sparse: each state's scores should pick few modules.
//   L_sparse = -(1/(M b)) sum_{s,i} g_i^(1/log M) log g_i. The exponent puts the maximum of -g^a log g exactly at
//   g = 1/M, so minimising pushes scores away from uniform, towards 0 or 1 (both give 0).

#include <cmath>
#include <stdexcept>

#include "maps/selector/selector_loss.h"

namespace maps::core {
namespace {

// Scores that underflow to 0 would give 0 * log 0 = NaN. A score at the floor contributes
// -(1e-30)^(1/log M) log(1e-30) instead of 0: 69 * 1e-30^(1/log M), which grows with M (1e-30 itself is raised to a
// power below 1): 1.6e-17 per score at M = 5, 6.5e-12 at M = 10, 6.7e-9 at M = 20: far below any logged digit.
constexpr double kScoreFloor = 1e-30;

class SparseLoss : public SelectorLoss {
 public:
  SparseLoss() : SelectorLoss("SparseLoss") {}
  std::string name() const override { return "sparse"; }

  ag::Tensor forward(const SelectorOutputs& out) override {
    const ag::Tensor& g = out.scores;  // [b, M]
    const double b = static_cast<double>(g.size(0)), M = static_cast<double>(g.size(1));
    if (g.size(1) < 2) throw std::invalid_argument("sparse selector loss: needs at least 2 modules (1/log M)");
    const ag::Tensor safe = ag::clamp_min(g, kScoreFloor);
    return ag::sum(ag::pow(safe, 1.0 / std::log(M)) * ag::log(safe)) * (-1.0 / (M * b));
  }

 protected:
  std::shared_ptr<Module> shallow_copy() const override { return std::make_shared<SparseLoss>(*this); }
};

}  // namespace

std::shared_ptr<SelectorLoss> make_sparse_loss() { return std::make_shared<SparseLoss>(); }

}  // namespace maps::core
