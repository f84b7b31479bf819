#include "lookboth/core/config_layers.h"

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/paths.h"

namespace lookboth {

std::vector<ConfigLayer> configurationLayers(const std::optional<std::filesystem::path>& user_file,
                                             const std::string& overrides) {
  std::vector<ConfigLayer> layers;
  const std::filesystem::path defaults = shareDirectory() / "config" / "default.yaml";
  if (std::filesystem::exists(defaults)) layers.push_back({readFile(defaults), defaults.string()});
  if (user_file) layers.push_back({readFile(*user_file), user_file->string()});
  if (!overrides.empty()) layers.push_back({overrides, kInMemorySettings});
  return layers;
}

}  // namespace lookboth
