# Registers a GoogleTest executable's tests with ctest one test *suite* per process (MAPS_CTEST_PER_SUITE), where
# gtest_discover_tests registers one process per test case. Run at build time (cmake -P, a POST_BUILD step of
# maps_add_test_suite) with:
#   TEST_EXECUTABLE  the test binary          CTEST_FILE   the ctest script to write
#   TEST_PREFIX      prefix of the test names  TEST_LABELS  the tests' LABELS
#   WORKING_DIR      the tests' working folder ISOLATED     suites whose cases need a process each (;-list)
# Why: each start of a sanitizer-instrumented test binary (15 to 60 MB) costs 0.1 to 0.17 CPU-s, and CI's ASan pass
# started 929 of them (about a minute of its two cores); per suite it starts 186. A suite whose cases share process
# state they cannot share (PluginsTest: a plugin's registrations are process-wide) is listed in ISOLATED.
cmake_minimum_required(VERSION 3.20)

foreach(var TEST_EXECUTABLE CTEST_FILE TEST_PREFIX TEST_LABELS WORKING_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "GTestSuites.cmake: ${var} is not set")
  endif()
endforeach()

execute_process(COMMAND "${TEST_EXECUTABLE}" --gtest_list_tests WORKING_DIRECTORY "${WORKING_DIR}"
                TIMEOUT 300 RESULT_VARIABLE status OUTPUT_VARIABLE listing ERROR_VARIABLE errors)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${TEST_EXECUTABLE} --gtest_list_tests exited ${status}:\n${listing}\n${errors}")
endif()

# The listing: "Suite." on its own line (then maybe "  # TypeParam = ..."), each case indented below it (then maybe
# "  # GetParam() = ..."). The comments go first: a printed parameter may hold ';' or an unbalanced '[', which would
# join or split CMake list items.
string(REGEX REPLACE " *#[^\n]*" "" listing "${listing}")
string(REPLACE ";" "\\;" listing "${listing}")
string(REPLACE "\n" ";" lines "${listing}")
set(suites)
set(suite "")
foreach(line IN LISTS lines)
  if(line STREQUAL "" OR line MATCHES "^Running main\\(\\) from ")  # gtest_main's greeting
    continue()
  endif()
  if(line MATCHES "^ +(.+)$")
    set(case "${CMAKE_MATCH_1}")
    if(case MATCHES "^DISABLED_" OR suite MATCHES "^(.*/)?DISABLED_")
      continue()  # GoogleTest skips them unless asked; gtest_discover_tests lists them as disabled
    endif()
    if(NOT suite IN_LIST suites)
      list(APPEND suites "${suite}")
    endif()
    list(APPEND "cases_${suite}" "${case}")
  elseif(line MATCHES "^([^ ].*)\\.$")
    set(suite "${CMAKE_MATCH_1}")
  else()
    message(FATAL_ERROR "${TEST_EXECUTABLE} --gtest_list_tests: unexpected line '${line}'")
  endif()
endforeach()
if(NOT suites)
  message(FATAL_ERROR "${TEST_EXECUTABLE} lists no test")
endif()

foreach(suite IN LISTS ISOLATED)
  if(NOT suite IN_LIST suites)
    message(FATAL_ERROR "${TEST_EXECUTABLE} has no test suite '${suite}' to isolate (renamed? an instantiated suite "
                        "is named with its prefix, Prefix/Suite)")
  endif()
endforeach()

set(script "")
macro(register name filter)
  string(APPEND script "add_test([==[${name}]==] [==[${TEST_EXECUTABLE}]==] [==[--gtest_filter=${filter}]==])\n"
                       "set_tests_properties([==[${name}]==] PROPERTIES WORKING_DIRECTORY [==[${WORKING_DIR}]==] "
                       "LABELS [==[${TEST_LABELS}]==] TIMEOUT 900)\n")
endmacro()
foreach(suite IN LISTS suites)
  if(suite IN_LIST ISOLATED)
    foreach(case IN LISTS "cases_${suite}")
      register("${TEST_PREFIX}${suite}.${case}" "${suite}.${case}")
    endforeach()
  else()
    # No SKIP_REGULAR_EXPRESSION: one skipped case would mark the whole suite skipped, failures included.
    register("${TEST_PREFIX}${suite}" "${suite}.*")
  endif()
endforeach()
file(WRITE "${CTEST_FILE}" "${script}")
