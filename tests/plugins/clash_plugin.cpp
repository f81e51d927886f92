// A plugin that registers a selector loss under a built-in's name ("share"): the loader refuses it.

#include <memory>

#include "maps/plugin.h"
#include "maps/selector/selector_loss.h"

MAPS_PLUGIN();

MAPS_REGISTER_SELECTOR_LOSS("share", [] { return maps::core::make_share_loss(); });
