# Sanitizer and fuzzing builds (doc/reliability.md, "Fuzzing and sanitizers").
#
#   LOOKBOTH_SANITIZE=ON  the project's code with AddressSanitizer and
#                         UndefinedBehaviorSanitizer (gcc or clang); every UB
#                         report aborts, so a test cannot pass over one.
#   LOOKBOTH_FUZZ=ON      also the libFuzzer targets of libs/*/fuzz (clang only).
#                         Implies the sanitizers, and adds libFuzzer's coverage
#                         instrumentation (-fsanitize=fuzzer-no-link) to the
#                         project's code, so that the same build also runs the
#                         unit tests (scripts/test.sh --sanitize, scripts/fuzz.sh).
#
# Only the project's code is instrumented: the dependencies are Debian's
# prebuilt libraries, which ASan handles through its malloc interceptors.
#
#   lookboth_add_fuzzer(<name> SOURCES ... DEPS ...)
#     -> the libFuzzer executable fuzz_<name>, run by scripts/fuzz.sh <name>.

option(LOOKBOTH_SANITIZE "Build project code with AddressSanitizer and UBSan" OFF)
option(LOOKBOTH_FUZZ "Build the libFuzzer targets (libs/*/fuzz); needs clang" OFF)
# UBSan doubles the compile time of optimised template-heavy code (Ceres,
# Eigen). The modules whose tests run solves, renders and odometry (solver,
# calib, detect, vo) keep the build type's -O1: at -O0 their tests run about
# 100 times slower than in Release and the heaviest do not end within an hour.
# These modules' libraries, whose tests run little of their own code, are
# compiled without optimisation.
set(LOOKBOTH_SANITIZE_O0_MODULES report pipeline studio CACHE STRING
  "Modules whose library is compiled at -O0 in sanitizer builds")

# A unit test's time limit [s]: the sanitizers make the rendering,
# odometry and adjustment tests several times slower. On 2 cores sim/render
# and vo/loop_closure each passed 1800 s (over 20 and 24 minutes of CPU,
# doc/reliability.md, "Fuzzing and sanitizers").
if(LOOKBOTH_SANITIZE OR LOOKBOTH_FUZZ)
  set(LOOKBOTH_TEST_TIMEOUT 3600)
else()
  set(LOOKBOTH_TEST_TIMEOUT 300)
endif()

if(LOOKBOTH_FUZZ AND NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  message(FATAL_ERROR "LOOKBOTH_FUZZ needs clang's libFuzzer; configure with "
    "-DCMAKE_CXX_COMPILER=clang++ (scripts/fuzz.sh does)")
endif()

if(LOOKBOTH_SANITIZE OR LOOKBOTH_FUZZ)
  # Directory-wide, so that every project target below gets them (the
  # module's include comes before the add_subdirectory calls).
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
    -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
  if(LOOKBOTH_FUZZ)
    add_compile_options(-fsanitize=fuzzer-no-link)
  endif()
  cmake_language(DEFER DIRECTORY ${CMAKE_SOURCE_DIR} CALL lookboth_sanitize_unoptimised_modules)
endif()

# Called once every module is defined: a -O0 after the build type's -O1.
function(lookboth_sanitize_unoptimised_modules)
  foreach(module IN LISTS LOOKBOTH_SANITIZE_O0_MODULES)
    if(TARGET lookboth_${module})
      target_compile_options(lookboth_${module} PRIVATE -O0)
    endif()
  endforeach()
endfunction()

function(lookboth_add_fuzzer name)
  if(NOT LOOKBOTH_FUZZ)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  set(target fuzz_${name})
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${ARG_DEPS})
  # libFuzzer's main() and driver; the project's code is already instrumented.
  target_link_options(${target} PRIVATE -fsanitize=fuzzer)
  target_include_directories(${target} PRIVATE ${PROJECT_SOURCE_DIR}/libs/core/fuzz)
  target_compile_definitions(${target} PRIVATE
    LOOKBOTH_SHARE_DIR="${LOOKBOTH_SHARE_DIR}"
    LOOKBOTH_TEST_DATA_DIR="${LOOKBOTH_TEST_DATA_DIR}")
  lookboth_target_defaults(${target})
  # The fuzz targets are warning-free with gcc's and clang's warnings alike,
  # whatever LOOKBOTH_WERROR says for the rest of this tree.
  target_compile_options(${target} PRIVATE -Werror)
  # Inputs a run of this target once found (crash, undefined behaviour,
  # hang), kept under fuzz/regressions/<name>/ after their fix: replayed as
  # a unit test, so that the sanitizer build keeps checking them.
  file(GLOB regressions ${CMAKE_CURRENT_SOURCE_DIR}/regressions/${name}/*)
  if(regressions)
    add_test(NAME fuzz/${name}_regressions COMMAND ${target} -rss_limit_mb=2048 -timeout=10
      ${regressions})
    # Undefined behaviour stops the replay whatever the caller's
    # environment says (UBSan otherwise reports and goes on).
    set_tests_properties(fuzz/${name}_regressions PROPERTIES LABELS unit TIMEOUT 120
      ENVIRONMENT "UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1")
  endif()
endfunction()
