#include <sstream>

#include "lookboth/calib/builtin_stages.h"
#include "lookboth/calib/stage_registry.h"
#include "lookboth/core/error.h"

namespace lookboth {

CameraRegistration& RegistrationProblem::camera(const std::string& label) {
  for (CameraRegistration& c : result.cameras) {
    if (c.label == label) return c;
  }
  CameraRegistration c;
  c.label = label;
  c.reason = "not processed";
  result.cameras.push_back(c);
  return result.cameras.back();
}

ErrorContext checkErrorContext(const StageConfig& config, const std::string& why) {
  std::string key;
  if (why.size() > 2 && why[0] == '\'') {
    if (const std::size_t end = why.find('\'', 1); end != std::string::npos)
      key = why.substr(1, end - 1);
  }
  for (auto layer = config.layers.rbegin(); layer != config.layers.rend(); ++layer) {
    if (!layer->reader || !layer->node.IsDefined() || !layer->node.IsMap()) continue;
    if (!key.empty()) {
      const YAML::Node value = layer->node[key];
      if (value.IsDefined()) return layer->reader->at(value, config.field + "." + key);
    }
  }
  for (auto layer = config.layers.rbegin(); layer != config.layers.rend(); ++layer) {
    if (layer->reader && layer->node.IsDefined() && !layer->node.IsNull())
      return layer->reader->at(layer->node, config.field);
  }
  return ErrorContext{"", 0, config.field, ""};
}

StageRegistry& StageRegistry::global() {
  static StageRegistry* registry = [] {
    auto* r = new StageRegistry;
    registerPaperStages(*r);
    return r;
  }();
  return *registry;
}

void StageRegistry::add(const std::string& name, const std::string& description,
                        StageFactory factory) {
  stages_[name] = Entry{description, std::move(factory)};
}

std::unique_ptr<RegistrationStage> StageRegistry::create(const std::string& name,
                                                         const StageConfig& config) const {
  const auto found = stages_.find(name);
  if (found == stages_.end()) {
    std::string known;
    for (const auto& [n, entry] : stages_) known += (known.empty() ? "" : ", ") + n;
    throw Error(ErrorContext{"", 0, "register.pipeline", ""},
                "unknown stage '" + name + "' (known: " + known + ")");
  }
  return found->second.factory(config);
}

std::vector<std::pair<std::string, std::string>> StageRegistry::list() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& [name, entry] : stages_) out.emplace_back(name, entry.description);
  return out;
}

namespace {

// A stage made of an options struct and a function.
template <typename Options,
          void (*Run)(RegistrationProblem&, const Options&, const ProgressReporter&)>
class FunctionStage : public RegistrationStage {
 public:
  FunctionStage(std::string name, Options options)
      : name_(std::move(name)), options_(std::move(options)) {}
  std::string name() const override { return name_; }
  void run(RegistrationProblem& problem, const ProgressReporter& progress) override {
    Run(problem, options_, progress);
  }

 private:
  std::string name_;
  Options options_;
};

template <typename Options,
          void (*Run)(RegistrationProblem&, const Options&, const ProgressReporter&)>
void addFunctionStage(StageRegistry& registry, const std::string& name,
                      const std::string& description) {
  registry.add(name, description, [name](const StageConfig& config) {
    return std::make_unique<FunctionStage<Options, Run>>(name, readStageOptions<Options>(config));
  });
}

}  // namespace

void registerPaperStages(StageRegistry& registry) {
  addFunctionStage<AssociateOptions, runAssociate>(
      registry, "associate", "robot pose at each detection (linear + slerp, no extrapolation)");
  addFunctionStage<MotionCalibrationOptions, runMotionCalibration>(
      registry, "motion_calibration",
      "metric scale and fisheye_from_marker from relative motions (paper eq. 1-2)");
  addFunctionStage<LookDownOptions, runLookDown>(
      registry, "look_down", "world_from_camera of each camera from its detections (eq. 3)");
  addFunctionStage<LookUpOptions, runLookUp>(
      registry, "look_up", "camera positions refined by fisheye reprojection of blobs (eq. 4-5)");
  addFunctionStage<JointOptions, runJoint>(
      registry, "joint",
      "one adjustment of trajectory, scale, fisheye_from_marker, cameras and clock offsets");
}

}  // namespace lookboth
