// The whole job from a recording to a registration, for the command line
// (`lookboth register`) and the desktop app alike:
//   1. detect   - when the dataset has frames but not their detections
//                 (markers in environment cameras, blobs in the fisheye);
//   2. odometry - in visual mode, when the dataset has no VO trajectory
//                 (the result is added to the dataset as trajectory "vo");
//   3. register - the configured stages (RegistrationController);
//   4. output   - the registration directory, written atomically.
// Steps 1-2 add their results to the dataset through augmentDataset (a
// complete new dataset swapped in, never a half-written one), so that the
// next run, the report and the desktop app find them; each says so in its
// step line. With write_back off they go to a temporary copy beside the
// output instead (images hard-linked for a folder, copied for a rawlog),
// removed when the run ends: the dataset is not touched.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/calib/pipeline.h"
#include "lookboth/core/progress.h"

namespace lookboth {

struct FullPipelineOptions {
  std::filesystem::path dataset;
  std::filesystem::path out;  ///< The registration directory.
  bool overwrite = false;     ///< Replace an existing `out`.
  TrajectoryMode mode = TrajectoryMode::kVisual;
  std::string trajectory_label;           ///< "" = "vo" (visual) or "odometry" (metric).
  std::filesystem::path trajectory_file;  ///< A TUM file instead of a dataset trajectory.
  std::optional<std::filesystem::path> config_file;  ///< Over share/lookboth/config/default.yaml.
  bool auto_detect = true;                           ///< Run detection when detections are missing.
  bool auto_odometry = true;  ///< Run odometry when the visual trajectory is missing.
  int threads = 0;            ///< Detection threads (0 = one per core).
  bool write_back = true;     ///< Add detections and odometry to the dataset (see above).
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
  std::vector<std::string> trajectories;  ///< Labels in the manifest.
  bool hasTrajectory(const std::string& label) const;
};
DatasetContents inspectDataset(const std::filesystem::path& dataset,
                               const ProgressReporter& progress);

/// What one step did: whether it ran, and a line saying what it did or why
/// it was skipped ("detect: 120 marker detections, ...").
struct StepOutcome {
  bool ran = false;
  std::string summary;
};

/// Step 1 alone: detection when `contents` (of options.dataset) shows frames
/// without their detections and options.auto_detect is set; else skipped.
/// (options.out is not used.)
/// `out`: where the augmented dataset goes (empty: into options.dataset).
StepOutcome runDetectStep(const FullPipelineOptions& options, const DatasetContents& contents,
                          const ProgressReporter& progress, const std::filesystem::path& out = {});
/// Step 2 alone: visual odometry in visual mode when the dataset has no VO
/// trajectory; else skipped. Throws lookboth::Error when it is needed but
/// cannot run (no fisheye frames, auto_odometry off, another label).
StepOutcome runOdometryStep(const FullPipelineOptions& options, const DatasetContents& contents,
                            const ProgressReporter& progress,
                            const std::filesystem::path& out = {});

struct FullPipelineResult {
  std::vector<std::string> steps;  ///< One line per step run or skipped, and why.
  RegistrationRun run;
};

/// Runs the steps above. Throws lookboth::Error on bad input (naming the
/// file or camera), StopRequested when stopped (the dataset stays complete:
/// either as it was or with the finished steps' additions).
FullPipelineResult runFullPipeline(const FullPipelineOptions& options,
                                   const ProgressReporter& progress);

}  // namespace lookboth
