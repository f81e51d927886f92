// A plugin built against another version of the library (its mark says 0.0.1): the loader refuses it before its
// registration below runs.

#include <memory>

#include "maps/plugin.h"
#include "maps/selector/selector_loss.h"

extern "C" __attribute__((used, visibility("default"))) const char maps_plugin_mark[] = MAPS_PLUGIN_MARK_PREFIX "0.0.1";

MAPS_REGISTER_SELECTOR_LOSS("plugin_from_another_version", [] { return maps::core::make_share_loss(); });
