// The configuration's layers: share/lookboth/config/default.yaml, then the
// user's file (--config) when given, then text held in memory (the desktop
// app's settings). Every module reads its own section (register:, detect:,
// odometry:) from each layer in turn, a later layer setting the keys it has;
// errors name the layer's source, line and field. A run reads the files
// once (RegistrationPipeline) and hands the layers to each module's reader
// (registrationConfigFrom, detectConfigFrom, odometryOptionsFrom); a command
// that runs one module alone reads them for it.
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace lookboth {

struct ConfigLayer {
  std::string text;    ///< YAML of a configuration file.
  std::string source;  ///< Its path, or kInMemorySettings.
};

/// How errors name the in-memory layer.
inline constexpr const char* kInMemorySettings = "the settings";

/// default.yaml (when the share folder has one), `user_file`, then
/// `overrides` (when not empty). Throws lookboth::Error naming a file that
/// cannot be read.
std::vector<ConfigLayer> configurationLayers(const std::optional<std::filesystem::path>& user_file,
                                             const std::string& overrides = "");

}  // namespace lookboth
