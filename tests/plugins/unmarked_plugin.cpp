// A shared library without MAPS_PLUGIN(): the loader does not load it (its registration below never runs).

#include <memory>

#include "maps/selector/selector_loss.h"

MAPS_REGISTER_SELECTOR_LOSS("plugin_without_mark", [] { return maps::core::make_share_loss(); });
