# Helpers shared by the layer folders and tests/.

# maps_precompile_headers(<target> [<header>...])
#
# Precompiles Eigen/Core (where the target links Eigen) and the given headers for <target> (MAPS_PRECOMPILE_HEADERS):
# every translation unit parsed them again, and the CI builds everything twice (the Release build took 676 s without and 461 s with them;
# docs/reliability.md). Only third-party headers: a header of ours that forgets an include still fails
# to compile in the installed-package test, which builds without them.
function(maps_precompile_headers target)
  if(NOT MAPS_PRECOMPILE_HEADERS)
    return()
  endif()
  # A precompiled header pays when three or more translation units load it: with unity batches of 8, a target of 16
  # sources or fewer compiles as one or two, and generating the header cost as much as it saved (a target of one
  # batch parsed the headers twice: once to precompile them, once more in the .gch's first and only user).
  get_target_property(sources ${target} SOURCES)
  list(FILTER sources INCLUDE REGEX "\\.(cpp|cc|cxx)$")
  list(LENGTH sources source_count)
  if(CMAKE_UNITY_BUILD)
    math(EXPR translation_units "(${source_count} + 7) / 8")
  else()
    set(translation_units ${source_count})
  endif()
  if(translation_units LESS 3)
    return()
  endif()
  # Eigen/Core only where Eigen is on the include path: every layer but maps_io, which reads files and knows no
  # matrices, brings it (directly or through another layer).
  get_target_property(links ${target} LINK_LIBRARIES)
  set(eigen "")
  foreach(link IN LISTS links)
    if(link STREQUAL "Eigen3::Eigen" OR (link MATCHES "^maps_" AND NOT link MATCHES "^maps_(io|warnings)$"))
      set(eigen <Eigen/Core>)
    endif()
  endforeach()
  if(eigen OR ARGN)
    target_precompile_headers(${target} PRIVATE ${eigen} ${ARGN})
  endif()
endfunction()

# maps_add_layer(<target> [EXCLUDE_DIRS <subfolders>...] [PUBLIC_DEPS <targets>...] [PRECOMPILE <headers>...])
#
# Builds the layer library of the calling folder from every *.cpp under it (recursively, with
# CONFIGURE_DEPENDS, so adding a file needs no CMake edit: the next build re-globs), except
# under EXCLUDE_DIRS (optional parts that get targets of their own).
# A folder with no .cpp yet gives an INTERFACE library with the same name, include directory
# and dependencies; it becomes a STATIC library by itself once the first .cpp appears. PRECOMPILE: headers
# precompiled beside Eigen/Core (maps_precompile_headers).
# The repository root is the public include directory ("autograd/tensor.h", "nn/linear.h"); installed, the
# headers are under <prefix>/include/maps/ and included as "maps/autograd/tensor.h" (cmake/MapsInstall.cmake).
function(maps_add_layer target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "" "PUBLIC_DEPS;EXCLUDE_DIRS;PRECOMPILE")
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS "${CMAKE_CURRENT_SOURCE_DIR}/*.cpp")
  foreach(dir IN LISTS arg_EXCLUDE_DIRS)
    list(FILTER sources EXCLUDE REGEX "^${CMAKE_CURRENT_SOURCE_DIR}/${dir}/")
  endforeach()
  if(sources)
    add_library(${target} STATIC ${sources})
    target_include_directories(${target} PUBLIC "$<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>"
                                                "$<INSTALL_INTERFACE:include>")
    target_link_libraries(${target} PUBLIC ${arg_PUBLIC_DEPS} PRIVATE maps_warnings)
    maps_precompile_headers(${target} ${arg_PRECOMPILE})
    list(LENGTH sources count)
    message(STATUS "${target}: static library from ${count} source file(s)")
  else()
    add_library(${target} INTERFACE)
    target_include_directories(${target} INTERFACE "$<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>"
                                                   "$<INSTALL_INTERFACE:include>")
    target_link_libraries(${target} INTERFACE ${arg_PUBLIC_DEPS})
    message(STATUS "${target}: no .cpp yet, interface library (headers and dependencies only)")
  endif()
endfunction()

# maps_add_test_suite(<layer> <libraries>... [TARGET <name>] [ISOLATE <suite>...])
#
# tests/<layer>/**/*.cpp -> executable maps_<layer>_tests (or <name>) linked with <libraries> and GoogleTest
# (gtest_main, plus gmock for matchers such as HasSubstr). Each TEST becomes a ctest test named
# "<layer>.<Suite>.<Name>" with label <layer>; with MAPS_CTEST_PER_SUITE each suite is one ctest test
# "<layer>.<Suite>" instead, but for the ISOLATE suites, whose cases cannot share a process. A folder with no .cpp yet
# is skipped.
function(maps_add_test_suite layer)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "TARGET" "ISOLATE")
  set(dir "${CMAKE_CURRENT_SOURCE_DIR}/${layer}")
  set(target maps_${layer}_tests)
  if(arg_TARGET)
    set(target ${arg_TARGET})
  endif()
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS "${dir}/*.cpp")
  if(NOT sources)
    message(STATUS "${target}: tests/${layer}/ has no .cpp yet, skipped")
    return()
  endif()
  add_executable(${target} ${sources})
  target_link_libraries(${target} PRIVATE ${arg_UNPARSED_ARGUMENTS} GTest::gmock GTest::gtest_main maps_warnings)
  target_compile_definitions(${target} PRIVATE MAPS_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  maps_precompile_headers(${target} <gmock/gmock.h> <gtest/gtest.h> <nlohmann/json.hpp>)
  if(MAPS_CTEST_PER_SUITE)
    # A ctest test per GoogleTest suite (cmake/GTestSuites.cmake says why), but for the ISOLATE suites' cases.
    set(ctest_file "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites.cmake")
    add_custom_command(TARGET ${target} POST_BUILD
      COMMAND "${CMAKE_COMMAND}" "-DTEST_EXECUTABLE=$<TARGET_FILE:${target}>" "-DCTEST_FILE=${ctest_file}"
              "-DTEST_PREFIX=${layer}." "-DTEST_LABELS=${layer}" "-DWORKING_DIR=${CMAKE_CURRENT_BINARY_DIR}"
              "-DISOLATED=${arg_ISOLATE}" -P "${PROJECT_SOURCE_DIR}/cmake/GTestSuites.cmake"
      BYPRODUCTS "${ctest_file}" VERBATIM)
    set(include_file "${CMAKE_CURRENT_BINARY_DIR}/${target}_suites_include.cmake")
    file(WRITE "${include_file}" "if(EXISTS \"${ctest_file}\")\n  include(\"${ctest_file}\")\nelse()\n"
                                 "  add_test(${target}_NOT_BUILT ${target}_NOT_BUILT)\nendif()\n")
    set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${include_file}")
    return()
  endif()
  gtest_discover_tests(${target}
    TEST_PREFIX "${layer}."
    NO_PRETTY_VALUES                 # parameterized tests keep their own names, not dumps of GetParam()
    DISCOVERY_TIMEOUT 300            # listing runs the binary; sanitized builds start slowly
    PROPERTIES LABELS ${layer} TIMEOUT 900)
endfunction()

# maps_export_for_plugins(<executable>)
#
# The executable loads C++ plugins (experiments/run/plugins.h): plugins link no layer library (a second copy would
# be a second set of registries) and take every library symbol they use from the executable. So it exports its
# symbols (ENABLE_EXPORTS: -rdynamic) and holds every object of the layers, not only those its own code calls (the
# archives linked whole).
function(maps_export_for_plugins target)
  set_target_properties(${target} PROPERTIES ENABLE_EXPORTS ON)
  set(archives)
  foreach(layer maps_io maps_autograd maps_nn maps_envs maps_core)
    get_target_property(type ${layer} TYPE)
    if(type STREQUAL "STATIC_LIBRARY")
      list(APPEND archives "$<TARGET_FILE:${layer}>")
    endif()
  endforeach()
  target_link_options(${target} PRIVATE "LINKER:--whole-archive" ${archives} "LINKER:--no-whole-archive")
endfunction()
