# Every dependency is a Debian package installed by scripts/setup.sh.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Ceres REQUIRED)
# CHOLMOD (libsuitesparse-dev), for the joint stage's fill-reducing ordering;
# Debian's package has no CMake config of its own.
if(NOT TARGET SuiteSparse::CHOLMOD)
  find_path(LOOKBOTH_CHOLMOD_INCLUDE_DIR suitesparse/cholmod.h REQUIRED)
  find_library(LOOKBOTH_CHOLMOD_LIBRARY NAMES cholmod REQUIRED)
  add_library(SuiteSparse::CHOLMOD UNKNOWN IMPORTED)
  set_target_properties(SuiteSparse::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${LOOKBOTH_CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${LOOKBOTH_CHOLMOD_INCLUDE_DIR}")
endif()
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc calib3d)
find_package(yaml-cpp REQUIRED)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(mrpt-core REQUIRED)
find_package(mrpt-poses REQUIRED)
find_package(mrpt-img REQUIRED)
find_package(mrpt-obs REQUIRED)
find_package(opengv REQUIRED)
if(LOOKBOTH_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(LOOKBOTH_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
endif()

# yaml-cpp 0.7 in Debian 12 exports the target "yaml-cpp" without a namespace.
if(TARGET yaml-cpp AND NOT TARGET yaml-cpp::yaml-cpp)
  add_library(yaml-cpp::yaml-cpp ALIAS yaml-cpp)
endif()
