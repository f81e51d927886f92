// A plugin that needs a function nothing defines (as one linked against a library the tool lacks would): the
// dynamic loader refuses it and the loader says so with its message.

#include "maps/plugin.h"

MAPS_PLUGIN();

extern "C" int maps_test_function_nobody_defines();
extern "C" __attribute__((visibility("default"))) int maps_test_plugin_calls_it() {
  return maps_test_function_nobody_defines();
}
