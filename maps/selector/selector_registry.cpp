#include <stdexcept>

#include "maps/selector/selector_loss.h"

namespace maps::core {

const std::vector<SelectorLossEntry>& selector_losses() {
  // One line per loss.
  static const std::vector<SelectorLossEntry> entries = {
      {"share", make_share_loss},
      {"explore", make_explore_loss},
      {"sparse", make_sparse_loss},
      {"smooth", make_smooth_loss},
  };
  return entries;
}

std::shared_ptr<SelectorLoss> make_selector_loss(const std::string& name) {
  std::string known;
  for (const auto& entry : selector_losses()) {
    if (entry.name == name) return entry.make();
    known += (known.empty() ? "" : ", ") + entry.name;
  }
  throw std::invalid_argument("unknown selector loss '" + name + "'; known: " + known);
}

}  // namespace maps::core
