# Run by `cmake --install` (install(SCRIPT)): the installed headers live under <prefix>/include/maps/, so users write
# #include "maps/autograd/tensor.h" and only maps/ is added to their include path. In the source tree the layers
# include each other as "io/...", "autograd/...", "nn/...", "envs/..." (the repository root is the include directory); this
# rewrites those includes in the installed copies to "maps/autograd/..." etc. The core layer's headers are already
# "maps/..." in both places. Input: HEADER_DIR, the installed include/maps folder.
file(GLOB_RECURSE headers "${HEADER_DIR}/*.h")
foreach(header IN LISTS headers)
  file(READ "${header}" text)
  string(REGEX REPLACE "#include \"(io|autograd|nn|envs)/" "#include \"maps/\\1/" prefixed "${text}")
  if(NOT prefixed STREQUAL text)
    file(WRITE "${header}" "${prefixed}")
  endif()
endforeach()
