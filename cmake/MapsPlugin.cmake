# maps_add_plugin(<name> <source>...)
#
# A C++ plugin of the `maps` tool (docs/extending.md): a shared library (lib<name>.so) of selector losses and methods
# that register themselves by name, one of whose sources says MAPS_PLUGIN(); (maps/plugin.h). It compiles against the
# library's headers (maps::plugin) and links none of its libraries: the tool that loads it has them all.
# Installed with the package (find_package(maps) includes this file) and used by the library's own test plugins.
function(maps_add_plugin name)
  if(NOT ARGN)
    message(FATAL_ERROR "maps_add_plugin(${name}): no sources given")
  endif()
  add_library(${name} MODULE ${ARGN})
  target_link_libraries(${name} PRIVATE maps::plugin)
  set_target_properties(${name} PROPERTIES PREFIX "lib")
endfunction()
