#pragma once

#include "io/version.h"

// A plugin is a shared library that the `maps` tool loads when a run or suite config names it ("plugins":
// ["libmylosses.so"]); its selector losses and methods register themselves by name (MAPS_REGISTER_SELECTOR_LOSS,
// MAPS_REGISTER_POLICY_METHOD) into the registries the built-ins are in (docs/extending.md). Exactly one of its
// .cpp files says
//
//   MAPS_PLUGIN();
//
// at namespace scope. That marks the file as a maps plugin and records the library version it was compiled against:
// the loader reads the mark from the file before loading it, so a plugin built against another version is refused
// (naming both versions) before any of its code runs, and a library without the mark is not loaded at all.
//
// A plugin links the CMake target maps::plugin (or uses maps_add_plugin()), never the layer libraries: the tool
// already holds them, and a second copy inside the plugin would be a second set of registries.
#define MAPS_PLUGIN_MARK_PREFIX "maps-plugin-abi:"

#define MAPS_PLUGIN()                                                                     \
  extern "C" __attribute__((used, visibility("default"))) const char maps_plugin_mark[] = \
      MAPS_PLUGIN_MARK_PREFIX MAPS_VERSION
