// Estimation stages and their registry. A stage is one step of the
// registration (associate, motion_calibration, look_down, look_up; later
// detect, odometry, joint...), created by name from its section of the
// configuration YAML. New stages register here; the controller
// (lookboth/pipeline/registration_controller.h) never changes for them.
#pragma once
#include <yaml-cpp/yaml.h>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "lookboth/calib/problem.h"
#include "lookboth/core/progress.h"
#include "lookboth/core/yaml_reader.h"

namespace lookboth {

class RegistrationStage {
 public:
  virtual ~RegistrationStage() = default;
  /// The name it is registered under.
  virtual std::string name() const = 0;
  /// Reads the problem, adds its results. Throws lookboth::Error when what it
  /// needs is missing (naming the stage that should come first), StopRequested
  /// when stopped.
  virtual void run(RegistrationProblem& problem, const ProgressReporter& progress) = 0;
};

/// The options section of one stage, possibly from two files: the defaults
/// (share/lookboth/config/default.yaml) and the user's --config, whose keys
/// override. `field` is the dotted path of the section ("register.look_down").
struct StageConfig {
  struct Layer {
    const YamlReader* reader = nullptr;
    YAML::Node node;  ///< The section (may be undefined or null).
  };
  std::vector<Layer> layers;  ///< In order: defaults first, the user's last.
  std::string field;
};

/// Where a `check()` message about a stage's options points: the file and
/// line of the last layer that sets the option the message names ('key': ...),
/// else of the last layer that has the section.
ErrorContext checkErrorContext(const StageConfig& config, const std::string& why);

/// Reads a stage's options from its layers: `Options::read(reader, node,
/// field)` is applied layer after layer (each sets the keys present and
/// rejects unknown ones), then `check()` (an error names the file, line and
/// option, see checkErrorContext).
template <typename Options>
Options readStageOptions(const StageConfig& config) {
  Options options;
  for (const StageConfig::Layer& layer : config.layers) {
    if (layer.node.IsDefined() && !layer.node.IsNull()) {
      options.read(*layer.reader, layer.node, config.field);
    }
  }
  if (const std::string why = options.check(); !why.empty()) {
    throw Error(checkErrorContext(config, why), why);
  }
  return options;
}

using StageFactory = std::function<std::unique_ptr<RegistrationStage>(const StageConfig&)>;

class StageRegistry {
 public:
  /// The process-wide registry, holding the built-in stages.
  static StageRegistry& global();
  /// Adds (or replaces) a stage.
  void add(const std::string& name, const std::string& description, StageFactory factory);
  bool has(const std::string& name) const { return stages_.count(name) > 0; }
  /// Throws lookboth::Error listing the known names for an unknown one.
  std::unique_ptr<RegistrationStage> create(const std::string& name,
                                            const StageConfig& config) const;
  /// (name, description), sorted by name.
  std::vector<std::pair<std::string, std::string>> list() const;

 private:
  struct Entry {
    std::string description;
    StageFactory factory;
  };
  std::map<std::string, Entry> stages_;
};

}  // namespace lookboth
