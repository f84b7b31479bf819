// The registration controller: one class for the command line and the
// desktop app. It loads the configuration (share/lookboth/config/default.yaml,
// then the user's file over it), reads the dataset's detections and
// trajectory, runs the configured stages in order with progress callbacks
// and a stop flag, and writes the output directory atomically.
#pragma once
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/calib/stage_registry.h"
#include "lookboth/core/config_layers.h"
#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/registration/facility_check.h"
#include "lookboth/registration/registration.h"

namespace lookboth {

/// The `register:` section of the configuration files, defaults first.
struct RegistrationConfig {
  std::vector<std::string> pipeline;  ///< Stage names, in order.
  /// The frame `register` writes the result in (`register.world_frame`):
  /// "floor" (z normal to the plane the robot drove on, fitted to the
  /// trajectory; origin and heading at the first pose on it;
  /// registration/site_frame.h) or "registration" (the first fisheye pose).
  /// The floor frame falls back to the registration's when the trajectory is
  /// no floor: fewer than 3 poses, a straight line, or positions farther than
  /// `floor_max_flatness_m` RMS from their plane (a hand-held or flying
  /// recording) [m].
  std::string world_frame = "floor";
  double floor_max_flatness_m = 0.05;
  std::vector<std::string> files;                    ///< The files read, defaults first.
  std::vector<StageConfig::Layer> layers;            ///< The `register` node of each file.
  std::vector<std::shared_ptr<YamlReader>> readers;  ///< Owns the layers' readers.
  /// The options section of a stage ("register.<name>") in every layer.
  StageConfig stageConfig(const std::string& name) const;
  /// The `register` sections merged (the user's keys over the defaults), as YAML text.
  std::string mergedYaml() const;
};

/// The `register:` sections of configurationLayers(user_file, overrides)
/// (core/config_layers.h): default.yaml, then `user_file` (when given),
/// then `overrides` (the YAML text of a configuration, e.g. the desktop
/// app's settings edited in memory; errors name it kInMemorySettings).
RegistrationConfig loadRegistrationConfig(const std::optional<std::filesystem::path>& user_file,
                                          const std::string& overrides = "");
/// The `register:` sections of `layers`, in order.
RegistrationConfig registrationConfigFrom(const std::vector<ConfigLayer>& layers);
/// The same from texts (source names for errors), defaults first.
RegistrationConfig registrationConfigFromYaml(
    const std::vector<std::pair<std::string, std::string>>& text_and_source);

struct RegisterOptions {
  std::filesystem::path dataset;
  TrajectoryMode mode = TrajectoryMode::kVisual;
  /// Dataset trajectory to use; "" = "vo" in visual mode, "odometry" in metric mode.
  std::string trajectory_label;
  /// A TUM file instead of a dataset trajectory (world_from_fisheye, robot clock).
  std::filesystem::path trajectory_file;
  /// Called for every problem found in the input (rows dropped as out of
  /// order or repeated, ...), as it is found.
  std::function<void(const DatasetIssue&)> on_issue;
  std::string check() const;
};

/// Reads the markers, blobs and the chosen trajectory of a dataset. Throws
/// lookboth::Error naming the dataset when the trajectory is absent (in
/// visual mode: telling to run `lookboth odometry`).
RegistrationInput loadRegistrationInput(const RegisterOptions& options,
                                        const ProgressReporter& progress);

class RegistrationController;

/// A registration run one stage at a time (the desktop app's "run stage"
/// buttons; RegistrationController::run uses it too). Made by
/// RegistrationController::prepare; the controller must outlive it.
class RegistrationSession {
 public:
  /// The configured stages, in order.
  std::size_t stageCount() const;
  const std::string& stageName(std::size_t i) const;
  /// How many stages have run (the index of the next one).
  std::size_t stagesRun() const { return next_; }
  bool finished() const { return next_ >= stageCount(); }
  /// Runs the next stage. Throws lookboth::Error when all have run, or from
  /// the stage; StopRequested when stopped (the stage then counts as not run
  /// and the problem may hold part of its work: prepare again to redo it).
  void runNext(const ProgressReporter& progress);
  /// `register --update` (lookboth/calib/record_update.h), once every stage
  /// has run: the registration so far against `record` (checkFacility), then
  /// the stage `joint` again in the record's frame with the unchanged cameras
  /// held at the record; current() is then the record updated. Returns the
  /// comparison. Throws lookboth::Error when the pipeline has no `joint` or
  /// the comparison cannot align the two (fewer than 3 cameras in common).
  FacilityCheck updateRecord(const Registration& record, const FacilityCheckOptions& options,
                             const ProgressReporter& progress);
  /// The registration as it stands after the stages run so far (after the
  /// last one: what RegistrationController::run returns).
  RegistrationRun current() const;
  const RegistrationProblem& problem() const { return problem_; }

 private:
  friend class RegistrationController;
  RegistrationSession(const RegistrationController& controller, RegistrationInput input);
  const RegistrationController* controller_;
  RegistrationProblem problem_;
  std::size_t next_ = 0;
  std::optional<Registration> record_;  ///< updateRecord's record: current() merges with it.
  FacilityCheck check_;
};

class RegistrationController {
 public:
  explicit RegistrationController(RegistrationConfig config,
                                  StageRegistry& registry = StageRegistry::global());
  /// Checks every stage's options now (an error names the section).
  const RegistrationConfig& config() const { return config_; }
  /// Runs the pipeline. Throws StopRequested when stopped, lookboth::Error on
  /// input no stage can work with.
  RegistrationRun run(RegistrationInput input, const ProgressReporter& progress) const;
  /// The same, one stage at a time: nothing runs until RegistrationSession::runNext.
  RegistrationSession prepare(RegistrationInput input) const;

 private:
  friend class RegistrationSession;
  RegistrationConfig config_;
  std::vector<std::unique_ptr<RegistrationStage>> stages_;
};

/// Throws (naming `dir`) when writeRegistrationOutput would refuse `dir`: its
/// parent directory missing, `dir` existing without `overwrite`, or `dir`
/// being or containing one of `inputs` (inputs are never written to). For a
/// caller to check before the work rather than after it.
void checkRegistrationOutput(const std::filesystem::path& dir, bool overwrite,
                             const std::vector<std::filesystem::path>& inputs = {});

/// Writes the output directory (cameras.csv, registration.yaml,
/// trajectory.tum, blob_associations.csv, scene.3Dscene) under a temporary
/// name beside `dir` and renames it into place. An existing `dir` is an error
/// unless `overwrite`.
void writeRegistrationOutput(const RegistrationRun& run, const std::filesystem::path& dir,
                             bool overwrite);

}  // namespace lookboth
