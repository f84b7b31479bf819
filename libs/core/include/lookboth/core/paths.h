#pragma once

#include <filesystem>

namespace lookboth {

/// The folder of lookboth's shared data (scenarios, configs, sample
/// calibrations), found in this order: $LOOKBOTH_SHARE_DIR; <prefix>/share/lookboth
/// beside the running executable's bin/ (an installed lookboth); the
/// source tree's share/lookboth (a build tree). Throws lookboth::Error
/// listing the places tried when none exists.
std::filesystem::path shareDirectory();

}  // namespace lookboth
