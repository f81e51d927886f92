// The plugin's mark (once per plugin): the library version it is built against, which the tool checks before
// loading it.
#include "maps/plugin.h"

MAPS_PLUGIN();
