#pragma once

#include <string>

namespace lookboth {

/// "0.1.0" and the like, from the CMake project version.
const char* versionString();

/// One line per library lookboth was built against, e.g. "Ceres 2.1.0".
std::string buildInfo();

}  // namespace lookboth
