# Helper functions that declare the project's targets with explicit source lists.
#
#   lookboth_add_library(<module> SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...] [SHARED])
#     -> target lookboth_<module>, alias lookboth::<module>, headers in
#        libs/<module>/include/lookboth/<module>/.
#   lookboth_add_test(<module>/<name> SOURCES ... DEPS ... [LABELS ...] [COST <seconds>])
#     -> a GoogleTest executable registered with ctest under the name <module>/<name>.
#        COST: about how long it runs, for a test that takes much longer than
#        most: ctest starts those first, so that a parallel run does not end
#        with one long test alone (a clean clone has no timings of its own).
#   lookboth_add_benchmark(<name> SOURCES ... DEPS ...)
#     -> a Google Benchmark executable (not run by ctest; see doc/benchmarks.md).

function(lookboth_target_defaults target)
  target_compile_options(${target} PRIVATE ${LOOKBOTH_WARNING_FLAGS})
  target_compile_features(${target} PUBLIC cxx_std_17)
endfunction()

function(lookboth_add_library module)
  cmake_parse_arguments(ARG "SHARED" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  set(target lookboth_${module})
  if(ARG_SHARED)
    add_library(${target} SHARED ${ARG_SOURCES})
  else()
    add_library(${target} ${ARG_SOURCES})
  endif()
  add_library(lookboth::${module} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  set_target_properties(${target} PROPERTIES OUTPUT_NAME lookboth-${module}
    VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
  lookboth_target_defaults(${target})
  install(TARGETS ${target} EXPORT lookbothTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endfunction()

# A test executable's own code (gtest's and Eigen's templates, little run
# time) is compiled with less optimisation than the libraries it tests: -O1
# in optimised builds, -O0 in sanitizer builds. Measured per file, that takes
# a quarter off the Release build's test files and half off the sanitizer
# tree's; the libraries keep the build type's flags.
function(lookboth_test_optimisation target)
  if(LOOKBOTH_SANITIZE OR LOOKBOTH_FUZZ)
    target_compile_options(${target} PRIVATE -O0)
  elseif(CMAKE_BUILD_TYPE MATCHES "^(Release|RelWithDebInfo)$")
    target_compile_options(${target} PRIVATE -O1)
  endif()
endfunction()

# A test's own temporary directory (TMPDIR, which temp_directory_path()
# and mkstemp follow): <build>/Testing/tmp/<test>. Tests name their files in
# the temporary directory after what they test; two tests, or the same test
# in two build trees (Release and the sanitizers' at once), then never
# write over each other's files.
function(lookboth_test_temporary_directory name)
  string(REPLACE "/" "_" leaf "${name}")
  set(dir "${CMAKE_BINARY_DIR}/Testing/tmp/${leaf}")
  file(MAKE_DIRECTORY "${dir}")
  set_property(TEST ${name} APPEND PROPERTY ENVIRONMENT "TMPDIR=${dir}")
endfunction()

# Every test executable's own files start from one precompiled header of
# what nearly all of them include (GoogleTest, Eigen, the standard library):
# parsed once for the build instead of once per file, about 1.7 s of CPU per
# file. A file compiled with other flags (e.g. its own -O0) has the compiler
# refuse the precompiled header (-Winvalid-pch, an error here): such a file
# sets SKIP_PRECOMPILE_HEADERS. The header is built by a test-like executable
# so that its flags (-fPIE, -O1) are the tests'. GCC only: clang refuses a
# precompiled header whose macros differ from the file's, and the test
# targets differ in their libraries' definitions.
function(lookboth_test_precompiled_header target)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "GNU" OR NOT LOOKBOTH_TEST_PCH)
    return()
  endif()
  if(NOT TARGET lookboth_test_pch)
    add_executable(lookboth_test_pch ${PROJECT_SOURCE_DIR}/cmake/test_pch.cpp)
    target_link_libraries(lookboth_test_pch PRIVATE Eigen3::Eigen GTest::gtest GTest::gtest_main)
    target_compile_definitions(lookboth_test_pch PRIVATE
      LOOKBOTH_SHARE_DIR="${LOOKBOTH_SHARE_DIR}"
      LOOKBOTH_TEST_DATA_DIR="${LOOKBOTH_TEST_DATA_DIR}")
    lookboth_target_defaults(lookboth_test_pch)
    lookboth_test_optimisation(lookboth_test_pch)
    target_precompile_headers(lookboth_test_pch PRIVATE
      <gtest/gtest.h> <Eigen/Core> <Eigen/Geometry>
      <algorithm> <cmath> <filesystem> <fstream> <map> <memory> <random> <sstream> <string> <vector>)
  endif()
  target_link_libraries(${target} PRIVATE Eigen3::Eigen)  # the header's include path
  target_precompile_headers(${target} REUSE_FROM lookboth_test_pch)
endfunction()

function(lookboth_add_test name)
  if(NOT LOOKBOTH_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "COST" "SOURCES;DEPS;LABELS" ${ARGN})
  string(REPLACE "/" "_" target "test_${name}")
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${target} PRIVATE
    LOOKBOTH_SHARE_DIR="${LOOKBOTH_SHARE_DIR}"
    LOOKBOTH_TEST_DATA_DIR="${LOOKBOTH_TEST_DATA_DIR}")
  lookboth_target_defaults(${target})
  lookboth_test_optimisation(${target})
  lookboth_test_precompiled_header(${target})
  add_test(NAME ${name} COMMAND ${target})
  set_tests_properties(${name} PROPERTIES LABELS "unit;${ARG_LABELS}"
    TIMEOUT ${LOOKBOTH_TEST_TIMEOUT})
  lookboth_test_temporary_directory(${name})
  if(ARG_COST)
    set_tests_properties(${name} PROPERTIES COST ${ARG_COST})
  endif()
endfunction()

function(lookboth_add_benchmark name)
  if(NOT LOOKBOTH_BUILD_BENCHMARKS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  set(target bench_${name})
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} benchmark::benchmark)
  target_compile_definitions(${target} PRIVATE LOOKBOTH_SHARE_DIR="${LOOKBOTH_SHARE_DIR}")
  lookboth_target_defaults(${target})
endfunction()
