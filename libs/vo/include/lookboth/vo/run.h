// `lookboth odometry`: the visual odometry over a dataset's fisheye frames.
//
// Frames are read and decoded (and downscaled to the working resolution) on
// a second thread, overlapped with tracking on the calling thread. Outputs
// (a TUM file) are written atomically, and only when the run completes.
#pragma once

#include <filesystem>
#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/augment.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/vo/odometry.h"
#include "lookboth/vo/options.h"

namespace lookboth::vo {

struct OdometryRunOptions {
  std::filesystem::path dataset;  ///< A rawlog dataset or a folder.
  OdometryOptions odometry;
  /// Add the trajectory to the dataset: PoseSample records labelled "vo"
  /// (replacing earlier ones) and TrajectoryInfo{"vo", metric false} in the
  /// manifest, through augmentDataset (crash-safe).
  bool write_dataset = true;
  /// Where the augmented dataset goes; empty = replace the input.
  std::filesystem::path out;
  std::filesystem::path tum_out;  ///< Trajectory in TUM format; empty = none.
  /// Landmark map (.ply or .txt, see landmark_map.h); empty = none.
  std::filesystem::path map_out;
  bool overwrite = false;     ///< Replace an existing `out`, `tum_out` or `map_out`.
  std::string camera;         ///< The fisheye's label; empty = the manifest's fisheye.
  double max_duration_s = 0;  ///< Only the first seconds of frames [s]; 0 = all.
  /// OpenCV's own worker threads off while the odometry runs (its two
  /// threads are the design). Off when other work runs OpenCV beside it:
  /// the setting is the process's.
  bool limit_opencv_threads = true;
  /// Another user of the fisheye's frames (register's blob search), so that
  /// a frame both want is decoded once. `wants` is asked of each fisheye
  /// frame the odometry reads (in the dataset's order, on the decoding
  /// thread; not those past max_duration_s), and `take` is given those it
  /// wants, decoded at full resolution (8-bit grey, shared: not to be
  /// written to), on that thread; frames only it wants are decoded for it
  /// alone. `read_all` is called once the dataset was read to its end with
  /// every frame offered (not when the run is stopped or fails first).
  /// `take` is needed with `wants`. Any of them throwing fails the run, and
  /// so does a frame the tap alone wants that cannot be decoded, as one of
  /// the odometry's own does; decode_seconds counts the tap's frames too.
  struct FrameTap {
    std::function<bool(const ImageFrame&)> wants;
    std::function<void(const ImageFrame&, const cv::Mat&)> take;
    std::function<void()> read_all;
  };
  FrameTap tap;
  /// Told of what the user should know while the dataset is written (e.g.
  /// waiting for another run that is rewriting it).
  std::function<void(const DatasetIssue&)> on_issue;
  std::string check() const;
};

/// Label and description of the trajectory written to datasets.
inline constexpr const char* kVoTrajectoryLabel = "vo";
inline constexpr const char* kVoTrajectoryDescription = "lookboth odometry";

struct OdometryRunSummary {
  OdometryResult result;
  std::string camera;  ///< Label of the fisheye used.
  int working_width = 0, working_height = 0;
  double decode_seconds = 0;  ///< Reading + decoding + downscaling (second thread).
  double track_seconds = 0;   ///< VisualOdometry::processFrame, all frames (this thread).
  double finish_seconds = 0;  ///< Final global adjustment.
  double wall_seconds = 0;
  std::optional<AteResult> ate;  ///< Against the dataset's "ground_truth" trajectory, if any.
  std::optional<AteResult> ate_keyframes;
  std::int64_t records_written = 0;       ///< PoseSample records added to the dataset.
  std::filesystem::path dataset_written;  ///< Empty when the dataset was not written.
};

OdometryRunSummary runOdometry(const OdometryRunOptions& options, const ProgressReporter& progress);

/// Adds `trajectory` to `dataset` as trajectory "vo" (PoseSample records and
/// the manifest's entry, replacing earlier ones), written to `out` (empty:
/// the dataset replaced) through augmentDataset; what runOdometry writes
/// when `write_dataset`, for a run made without it.
AugmentSummary addOdometryTrajectory(const std::filesystem::path& dataset,
                                     const std::filesystem::path& out, bool overwrite,
                                     const Trajectory& trajectory,
                                     const std::function<void(const DatasetIssue&)>& on_issue,
                                     const ProgressReporter& progress);

}  // namespace lookboth::vo
