// The whole job from a recording to a registration, for the command line
// (`lookboth register`) and the desktop app alike:
//   1. detect   - when the dataset has frames but not their detections
//                 (markers in environment cameras, blobs in the fisheye);
//   2. odometry - in visual mode, when the dataset has no VO trajectory
//                 (the result is added to the dataset as trajectory "vo");
//   3. register - the configured stages (RegistrationController);
//   4. update   - with FullPipelineOptions::update_record only: the record
//                 updated by this drive (RegistrationSession::updateRecord);
//   5. output   - the registration directory, written atomically, in the
//                 configured frame (RegistrationConfig::world_frame: the
//                 floor's by default).
// Steps 1-2 add their results to the dataset through augmentDataset (a
// complete new dataset swapped in, never a half-written one), so that the
// next run, the report and the desktop app find them; each says so in its
// step line. With write_back off they go to a temporary copy beside the
// output instead (images hard-linked for a folder, copied for a rawlog),
// removed when the run ends: the dataset is not touched. When both are
// needed, step 1 runs the odometry beside detection and writes both
// (FullPipelineOptions::overlap_steps); step 2 then says what it did.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/core/config_layers.h"
#include "lookboth/core/progress.h"
#include "lookboth/pipeline/registration_controller.h"

namespace lookboth {

struct DetectOptions;

struct FullPipelineOptions {
  std::filesystem::path dataset;
  std::filesystem::path out;  ///< The registration directory.
  bool overwrite = false;     ///< Replace an existing `out`.
  /// Which trajectory to register with. With choose_trajectory set, mode and
  /// trajectory_label are chosen from the dataset (chooseTrajectory) and a
  /// step line says which; else they are used as given.
  bool choose_trajectory = false;
  TrajectoryMode mode = TrajectoryMode::kVisual;
  std::string trajectory_label;           ///< "" = "vo" (visual) or "odometry" (metric).
  std::filesystem::path trajectory_file;  ///< A TUM file instead of a dataset trajectory.
  std::optional<std::filesystem::path> config_file;  ///< Over share/lookboth/config/default.yaml.
  /// YAML text of a configuration over config_file, for every section
  /// (configurationLayers' `overrides`: the desktop app's settings, edited in memory).
  std::string config_overrides;
  bool auto_detect = true;    ///< Run detection when detections are missing.
  bool auto_odometry = true;  ///< Run odometry when the visual trajectory is missing.
  int threads = 0;            ///< Detection threads (0 = one per core).
  /// When both detection and odometry run, the detect step runs the
  /// odometry on a thread of its own beside detection's and writes both once
  /// both are done (the detections also when the odometry fails; nothing
  /// when stopped); the odometry step then reports it. Off: one after the other.
  bool overlap_steps = true;
  bool write_back = true;  ///< Add detections and odometry to the dataset (see above).
  /// A registration on record to update with this drive (`register --update`;
  /// lookboth/calib/record_update.h): adds the step "update" before the
  /// output, which is then the record updated, in the record's frame.
  std::filesystem::path update_record;
  FacilityCheckOptions update_check;  ///< What counts as moved, for update_record.
  /// Problems found in the input as it is read (rows dropped, frames skipped).
  std::function<void(const DatasetIssue&)> on_issue;
  std::string check() const;
};

/// What the dataset holds, for deciding which steps are needed.
struct DatasetContents {
  std::int64_t fisheye_frames = 0;
  std::int64_t camera_frames = 0;  ///< Environment cameras' frames.
  std::int64_t markers = 0;
  std::int64_t blob_records = 0;
  std::vector<TrajectoryInfo> trajectories;  ///< As the manifest describes them.
  /// The recording's span: its earliest and latest record [ns]; equal when empty.
  TimeNs first = 0, last = 0;
  bool hasTrajectory(const std::string& label) const;
};
DatasetContents inspectDataset(const std::filesystem::path& dataset,
                               const ProgressReporter& progress);

/// The trajectory a registration uses when the user names none, and why.
struct TrajectoryChoice {
  TrajectoryMode mode = TrajectoryMode::kVisual;
  std::string label;   ///< The dataset trajectory ("vo" also when odometry must make it).
  std::string reason;  ///< One line for the user: what was chosen and how to choose another.
};
/// The dataset's own description decides, in this order (ground truth never):
///   1. its visual odometry "vo" (visual mode);
///   2. its only trajectory marked not metric (visual mode: the scale is
///      estimated), e.g. the user's own monocular SLAM;
///   3. "vo" made by `lookboth odometry` when it has fisheye frames;
///   4. its metric trajectory "odometry", else its only metric one (metric mode).
/// Throws lookboth::Error listing the trajectories when none of these applies
/// or the choice is ambiguous (several unscaled ones).
TrajectoryChoice chooseTrajectory(const std::filesystem::path& dataset,
                                  const DatasetContents& contents);

/// What one step did: whether it ran, and a line saying what it did or why
/// it was skipped ("detect: 120 marker detections, ...").
struct StepOutcome {
  bool ran = false;
  std::string summary;
};

/// Step 1 alone: detection when `contents` (of options.dataset) shows frames
/// without their detections and options.auto_detect is set; else skipped.
/// Its options are the `detect:` sections of `layers` (configurationLayers).
/// (options.out is not used.)
/// `out`: where the augmented dataset goes (empty: into options.dataset).
StepOutcome runDetectStep(const FullPipelineOptions& options,
                          const std::vector<ConfigLayer>& layers, const DatasetContents& contents,
                          const ProgressReporter& progress, const std::filesystem::path& out = {});
/// Step 2 alone: visual odometry in visual mode when the dataset has no VO
/// trajectory; else skipped. Its options are the `odometry:` sections of
/// `layers`. Throws lookboth::Error when it is needed but cannot run (no
/// fisheye frames, auto_odometry off, another label).
StepOutcome runOdometryStep(const FullPipelineOptions& options,
                            const std::vector<ConfigLayer>& layers, const DatasetContents& contents,
                            const ProgressReporter& progress,
                            const std::filesystem::path& out = {});

/// How long a step of the pipeline took (wall clock).
struct StepTime {
  std::string step;  ///< "detect", "odometry", a stage's name, "output".
  double seconds = 0;
  bool ran = false;  ///< False when the step was skipped (e.g. detections already there).
};

struct FullPipelineResult {
  std::vector<std::string> steps;  ///< One line per step run or skipped, and why.
  RegistrationRun run;             ///< As written (RegistrationPipeline::written).
  /// With update_record: this drive's own registration against the record.
  std::optional<FacilityCheck> check;
  std::vector<StepTime> times;  ///< Every step, in order (a skipped one takes next to nothing).
  double drive_seconds = 0;     ///< The recording's span (DatasetContents first to last).
};

/// "run time: detect 12.3 s, odometry 8.1 s, stages 0.9 s, output 0.2 s; 21.5 s in all, 0.59x the
/// drive (36.3 s)": how the work compares with the recording it processed.
std::string describeTimes(const FullPipelineResult& result);

/// The steps above as one controller, for the command line (run) and the
/// desktop app (runNext, one step per job): "detect", "odometry", each
/// configured stage by name, "update" (with update_record), "output". Throws lookboth::Error on bad
/// input (naming the file or camera), StopRequested when stopped (the dataset stays complete:
/// either as it was or with the finished steps' additions; a stopped stage counts as not run, and
/// the run must start again).
class RegistrationPipeline {
 public:
  /// Checks the options and reads the registration configuration (a typo
  /// fails before any work).
  explicit RegistrationPipeline(FullPipelineOptions options);
  ~RegistrationPipeline();
  RegistrationPipeline(RegistrationPipeline&&) noexcept;

  const std::vector<std::string>& steps() const { return steps_; }
  /// The steps run so far and how long each took.
  const std::vector<StepTime>& times() const { return times_; }
  std::size_t stepsRun() const { return next_; }
  bool finished() const { return next_ >= steps_.size(); }
  /// Runs the next step (the first also inspects the dataset and chooses
  /// the trajectory); its line says what it did or why it was skipped.
  StepOutcome runNext(const ProgressReporter& progress);
  /// Every remaining step.
  FullPipelineResult run(const ProgressReporter& progress);
  /// The stages' session once the first stage has run (its current()
  /// registration), else null.
  const RegistrationSession* session() const;
  /// Once every step has run (the desktop app's *Update the record*): the
  /// update against `record` (RegistrationSession::updateRecord), written to
  /// `out` (never inside the record, never over an existing folder); written()
  /// is then the record updated. Returns the comparison with the record.
  FacilityCheck updateRecord(const std::filesystem::path& record,
                             const FacilityCheckOptions& options, const std::filesystem::path& out,
                             const ProgressReporter& progress);
  /// The registration the output step wrote (in the configured frame,
  /// RegistrationConfig::world_frame), once it has run, else null.
  const RegistrationRun* written() const;
  /// The dataset the steps read: the user's, or the scratch copy without write_back.
  const std::filesystem::path& dataset() const;

 private:
  struct State;
  void prepare(const ProgressReporter& progress);
  StepOutcome detect(const ProgressReporter& progress);
  StepOutcome odometry(const ProgressReporter& progress);
  /// Detection with the odometry on a thread beside it (overlap_steps),
  /// both awaited and written in this step; the odometry step then says what
  /// the odometry did.
  StepOutcome detectAlongsideOdometry(DetectOptions detect, const ProgressReporter& progress);
  StepOutcome stage(const ProgressReporter& progress);
  StepOutcome update(const ProgressReporter& progress);
  StepOutcome output(const ProgressReporter& progress);
  double driveSeconds() const;  ///< The recording's span [s].
  /// The session's registration with the run's times (detection, odometry, the drive's span).
  RegistrationRun currentRun() const;

  FullPipelineOptions options_;
  std::unique_ptr<State> state_;
  std::vector<std::string> steps_;
  std::vector<std::string> lines_;  ///< What each step did, for FullPipelineResult::steps.
  std::vector<StepTime> times_;
  std::size_t next_ = 0;
  bool prepared_ = false;
};

/// RegistrationPipeline(options).run(progress).
FullPipelineResult runFullPipeline(const FullPipelineOptions& options,
                                   const ProgressReporter& progress);

}  // namespace lookboth
