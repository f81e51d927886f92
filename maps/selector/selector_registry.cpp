#include <deque>
#include <stdexcept>
#include <utility>

#include "maps/selector/selector_loss.h"

namespace maps::core {

namespace {

io::Registry<SelectorLossEntry>& registry() {
  static io::Registry<SelectorLossEntry> losses("selector loss", [] {
    // One line per built-in loss.
    return std::deque<SelectorLossEntry>{
        {"share", make_share_loss},
        {"explore", make_explore_loss},
        {"sparse", make_sparse_loss},
        {"smooth", make_smooth_loss},
    };
  });
  return losses;
}

}  // namespace

const std::deque<SelectorLossEntry>& selector_losses() { return registry().entries(); }

std::string selector_loss_names() { return registry().names(); }

void register_selector_loss(const std::string& name, SelectorLossFactory make) {
  if (!make) throw std::invalid_argument("selector loss '" + name + "': no factory given");
  registry().add({name, std::move(make)});
}

std::string selector_loss_origin(const std::string& name) { return registry().origin_of(name); }

std::shared_ptr<SelectorLoss> make_selector_loss(const std::string& name) {
  for (const auto& entry : selector_losses())
    if (entry.name == name) return entry.make();
  throw std::invalid_argument("unknown selector loss '" + name + "'; known: " + selector_loss_names());
}

}  // namespace maps::core
