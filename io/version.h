#pragma once

// The library's version, compiled into every program and plugin built against it: the plugin loader refuses a plugin
// built against another version, whose view of the library's classes may differ from the tool's. It is the
// project's version (CMakeLists.txt); io/CMakeLists.txt stops the configure step when the two differ.
#define MAPS_VERSION "0.1.0"
