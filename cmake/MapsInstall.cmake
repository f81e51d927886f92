# `cmake --install build --prefix P`: the layer libraries (static), their headers under P/include/maps/ and a CMake
# package, so that another project can do
#   find_package(maps CONFIG REQUIRED)
#   target_link_libraries(app PRIVATE maps::autograd)   # or maps::io, maps::nn, maps::envs, maps::core
#   maps_add_plugin(mylosses mylosses.cpp)               # a C++ plugin the installed `maps` tool loads
# (tests/install/ builds such a project against an install in a temporary folder.)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(_maps_installed maps_io maps_autograd maps_nn maps_envs maps_core)
# Eigen's heap blocks must be aligned alike in the library and in its users: built with -march=native (AVX-512:
# 64-byte alignment, Eigen's own aligned malloc) and used from code built without it (16 bytes: plain malloc and
# free), a matrix made on one side and freed on the other corrupts the heap. One bound for both sides, on the two
# lowest layers that every other one links.
foreach(target maps_autograd maps_envs)
  target_compile_definitions(${target} PUBLIC EIGEN_MAX_ALIGN_BYTES=64)
endforeach()
foreach(target IN LISTS _maps_installed)
  string(REGEX REPLACE "^maps_" "" name "${target}")
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  add_library(maps::${name} ALIAS ${target})
endforeach()
# What a C++ plugin compiles against (cmake/MapsPlugin.cmake): the headers and the definitions that must agree with
# the library's (EIGEN_MAX_ALIGN_BYTES above; Eigen never starts threads), and the header-only dependencies. No layer
# library: the tool that loads the plugin holds them (maps_export_for_plugins).
add_library(maps_plugin INTERFACE)
target_include_directories(maps_plugin INTERFACE "$<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>" "$<INSTALL_INTERFACE:include>")
target_compile_definitions(maps_plugin INTERFACE EIGEN_MAX_ALIGN_BYTES=64 EIGEN_DONT_PARALLELIZE)
target_compile_features(maps_plugin INTERFACE cxx_std_20)
target_link_libraries(maps_plugin INTERFACE Eigen3::Eigen nlohmann_json::nlohmann_json)
set_target_properties(maps_plugin PROPERTIES EXPORT_NAME plugin)
add_library(maps::plugin ALIAS maps_plugin)
include(${PROJECT_SOURCE_DIR}/cmake/MapsPlugin.cmake)
install(FILES ${PROJECT_SOURCE_DIR}/cmake/MapsPlugin.cmake DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/maps)
# Linked PRIVATE by every layer (warning flags only); a static library's private links travel with its export.
set_target_properties(maps_warnings PROPERTIES EXPORT_NAME warnings)
install(TARGETS ${_maps_installed} maps_warnings maps_plugin EXPORT mapsTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/maps)
# Headers under one prefix: include/maps/{autograd,nn,envs}/ and the core layer's folders (policies/, training/, ...)
# beside them, included as "maps/autograd/tensor.h", "maps/policies/maps_policy.h".
foreach(layer io autograd nn envs)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${layer}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/maps/${layer}
          FILES_MATCHING PATTERN "*.h" PATTERN "render" EXCLUDE)
endforeach()
install(DIRECTORY ${PROJECT_SOURCE_DIR}/maps/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/maps FILES_MATCHING PATTERN "*.h")
install(CODE "execute_process(COMMAND \"${CMAKE_COMMAND}\"
                \"-DHEADER_DIR=\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_INCLUDEDIR}/maps\"
                -P \"${PROJECT_SOURCE_DIR}/cmake/prefix_installed_includes.cmake\" COMMAND_ERROR_IS_FATAL ANY)")
# The data the envs read at run time (MJCF scenes, committed experts): found there when the source tree is gone
# (envs/source_folders.cpp; MAPS_INSTALL_DATADIR below).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/envs/assets ${PROJECT_SOURCE_DIR}/envs/experts
        DESTINATION ${CMAKE_INSTALL_DATADIR}/maps/envs)
# The tool (bin/maps) and what it reads at run time besides the envs' data, found under share/maps/experiments/ when
# the source tree is gone: the report scripts, the format converters, the Python tools' JSON reader, the suite
# configs and the cost table, the example run configs.
if(TARGET maps)
  install(TARGETS maps RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  foreach(folder report interop process cluster)
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/experiments/${folder}/ DESTINATION ${CMAKE_INSTALL_DATADIR}/maps/experiments/${folder}
            FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)
  endforeach()
  foreach(folder suites configs)
    install(DIRECTORY ${PROJECT_SOURCE_DIR}/experiments/${folder}/
            DESTINATION ${CMAKE_INSTALL_DATADIR}/maps/experiments/${folder} FILES_MATCHING PATTERN "*.json")
  endforeach()
endif()
install(EXPORT mapsTargets NAMESPACE maps:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/maps)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/mapsConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/mapsConfig.cmake
                              INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/maps)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/mapsConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/mapsConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/mapsConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/maps)
