// Monocular visual odometry on the raw fisheye image, with loop closure.
//
// Frames go in one at a time (downscaled to the working resolution by
// `prepareImage`, which may run on another thread). Features are tracked in
// the raw image (pyramidal Lucas-Kanade), turned into unit bearings by the
// camera model and never rectified. The map holds keyframes (poses
// world_from_fisheye, world = the first keyframe, unknown scale) and
// landmarks; each new keyframe triggers a local bundle adjustment of the last
// `local_window` keyframes and a loop-closure query (ORB words, rotation
// invariant so that a place revisited in the opposite direction is found),
// verified by a 3D-3D similarity; a closed loop runs a Sim(3) pose graph and
// then a global bundle adjustment of all keyframes. Deterministic for given
// options (seed) and frames.
#pragma once

#include <Eigen/Core>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/geometry/time.h"
#include "lookboth/geometry/trajectory.h"
#include "lookboth/vo/options.h"

namespace lookboth::vo {

struct OdometryStatistics {
  std::int64_t frames = 0;          ///< Frames given.
  std::int64_t tracked_frames = 0;  ///< Frames that got a pose.
  std::int64_t keyframes = 0;
  std::int64_t landmarks = 0;  ///< Landmarks in the map at the end.
  std::int64_t loop_closures = 0;
  std::int64_t tracking_losses = 0;  ///< Times tracking was lost (after initialisation).
  std::int64_t relocalisations = 0;  ///< Losses recovered against the map.
  std::int64_t segments = 0;         ///< Maps started (1 + losses not relocalised).
  /// Segments left at the end: a later segment joined to an earlier one by
  /// a loop closure is no longer counted.
  std::int64_t segments_at_end = 0;
  /// Heap bytes held by the map and the place-recognition index at the end
  /// (capacity of their containers; grows with the keyframes).
  std::int64_t map_bytes = 0;
  /// Problems the global adjustment solved, and the size of the largest: its
  /// observations (residual blocks) and keyframes (what its memory grows with).
  std::int64_t global_problems = 0;
  std::int64_t global_largest_observations = 0;
  std::int64_t global_largest_keyframes = 0;
  double mean_tracked_features = 0;  ///< Per tracked frame.
  double mean_inliers = 0;           ///< Pose inliers per tracked frame.
  /// CPU seconds (of the tracking thread) spent per stage: "klt", "pose", "keyframe", "local_ba",
  /// "loop_detect", "loop_correct", "global_ba", "detect" (new features), "init".
  std::map<std::string, double> stage_seconds;
  std::vector<std::string> events;  ///< Losses, relocalisations, loops, one line each.
  /// Closed loops: (time of the current keyframe, time of the old one).
  std::vector<std::pair<TimeNs, TimeNs>> loops;
};

/// A landmark of the final map.
struct MapPoint {
  Eigen::Vector3d p_in_world = Eigen::Vector3d::Zero();  ///< World = first keyframe, VO units.
  int observations = 0;                                  ///< Keyframes that observe it.
  TimeNs first_seen = 0;  ///< Time of the keyframe where it was triangulated (its reference).
};

struct OdometryResult {
  /// world_from_fisheye of every tracked frame (or of the keyframes, option
  /// all_frames), after the final global adjustment.
  Trajectory trajectory;
  Trajectory keyframes;  ///< world_from_fisheye of the keyframes (final).
  /// The same frames before any loop closure and global adjustment (to
  /// report what loop closure brings).
  Trajectory trajectory_before_loop_closure;
  /// The valid landmarks after the final global adjustment (same frame as
  /// the trajectories).
  std::vector<MapPoint> landmarks;
  OdometryStatistics statistics;
};

class VisualOdometry {
 public:
  /// Throws lookboth::Error when options are invalid.
  VisualOdometry(const Camera& camera, const OdometryOptions& options);
  ~VisualOdometry();
  VisualOdometry(const VisualOdometry&) = delete;
  VisualOdometry& operator=(const VisualOdometry&) = delete;

  /// Integer downscaling factor from the camera's width to the working width.
  static int downscaleFactor(int image_width, const OdometryOptions& options);
  /// 8-bit grey image at the working resolution from a decoded frame (grey or BGR).
  static cv::Mat prepareImage(const cv::Mat& image, int factor);

  /// Processes one frame (already prepared). Returns true when it got a pose.
  /// Frames must come in increasing time.
  bool processFrame(TimeNs t, const cv::Mat& working_image);

  /// Final global adjustment; returns the trajectories and statistics.
  OdometryResult finish();

  const OdometryStatistics& statistics() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// CPU time consumed by the calling thread so far [s].
double threadCpuSeconds();

/// Absolute trajectory error after Sim(3) alignment of `estimate` onto
/// `ground_truth` (samples matched by time within `max_dt`).
struct AteResult {
  double rmse = 0;         ///< [ground-truth units, m].
  double path_length = 0;  ///< Ground-truth path over the matched samples [m].
  double scale = 0;        ///< Of the alignment.
  int matched = 0;
  double percent() const { return path_length > 0 ? 100.0 * rmse / path_length : 0; }
};
std::optional<AteResult> absoluteTrajectoryError(const Trajectory& estimate,
                                                 const Trajectory& ground_truth,
                                                 TimeNs max_dt = 1000000);

}  // namespace lookboth::vo
