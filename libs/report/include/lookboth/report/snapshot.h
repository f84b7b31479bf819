// `lookboth snapshot`: PNG pictures of a registration, made without any
// display (OpenCV drawing; MRPT's CFBORender through EGL for the 3-D view):
//
//   fisheye_check_f<index>_t<seconds>s.png   reprojection check on a fisheye frame (fig. 7)
//   env_view_<camera>_t<seconds>s.png        an environment camera's view of the marker (fig. 5)
//   overview_3d.png                          trajectory, cameras, detection rays (fig. 1)
//   compare_top_side_vs_<reference>.png      camera positions against a reference (fig. 9)
//   trajectory_loop_closure_<label>.png      a VO trajectory before/after loop closure (fig. 8)
//
// Times in file names and legends are seconds since the first fisheye frame.
#pragma once

#include <filesystem>
#include <map>
#include <opencv2/core.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/geometry/trajectory.h"
#include "lookboth/report/draw.h"
#include "lookboth/report/pose_comparison.h"

namespace lookboth {
struct Registration;
}

namespace lookboth::report {

/// What the pictures need from a registration.
struct RegistrationView {
  std::string name = "registration";
  std::map<std::string, Rigid3d> world_from_camera;         ///< Final poses (registered, suspect).
  std::map<std::string, Rigid3d> world_from_camera_before;  ///< Before the looking-up refinement.
  std::set<std::string> suspect;
  std::vector<std::string> unregistered;
  Trajectory trajectory;  ///< Metric world_from_fisheye.
  std::optional<Rigid3d> fisheye_from_marker;
  /// Stage 4's associations: blob, camera, projections before and after
  /// (ReprojectionRow::t is the fisheye frame time).
  std::vector<ReprojectionRow> blob_associations;
  /// The camera poses as a CameraPoseSet (for comparisons).
  CameraPoseSet poseSet() const;
};

/// The view of a registration loaded with loadRegistration (libs/calib).
RegistrationView viewOfRegistration(const Registration& registration, const std::string& name);

/// The reprojection check of the fisheye frame at `t` (robot clock) with the
/// blobs detected in it: the cameras projected before and after the
/// looking-up refinement, and stage 4's associations at that time.
FisheyeCheck makeFisheyeCheck(const RegistrationView& reg, const Camera& fisheye, TimeNs t,
                              const std::vector<Eigen::Vector2d>& frame_blobs);
/// Which fisheye frames to check.
struct FrameSelection {
  enum class Mode { kAuto, kIndices, kTimeRange } mode = Mode::kAuto;
  std::vector<int> indices;   ///< kIndices: 0-based among the fisheye frames.
  double t0_s = 0, t1_s = 0;  ///< kTimeRange: seconds since the first fisheye frame.
  /// "auto", "3,10,42" or "12.5:14" (throws lookboth::Error naming '--frames').
  static FrameSelection parse(const std::string& text);
};

struct SnapshotOptions {
  std::filesystem::path out;  ///< Folder for the PNGs (created when absent).
  FrameSelection frames;
  /// Size of every picture [px]; {0, 0}: camera pictures at the image's own
  /// size, plots and the 3-D overview at 1280x720.
  cv::Size size{0, 0};
  int auto_frames = 6;     ///< Frames picked by --frames auto.
  int max_env_views = 12;  ///< Environment camera pictures at most (0 = none).
  bool overview = true;    ///< Render the 3-D overview (needs EGL).
  int max_rays = 400;      ///< Detection rays drawn in the overview at most.
  /// References to compare with (ground truth, other registrations): one
  /// top/side picture each.
  struct Reference {
    std::string name;  ///< For file names and legends: "ground_truth", "run2"...
    CameraPoseSet poses;
  };
  std::vector<Reference> references;
  bool reference_with_scale = false;  ///< Align the references with Sim(3).
  std::string check() const;
};

struct SnapshotPicture {
  std::filesystem::path file;
  std::string kind;     ///< "fisheye_check", "env_view", "overview_3d", "compare", "loop_closure".
  std::string caption;  ///< One sentence saying what it shows.
  cv::Size size;
  TimeNs t = 0;                    ///< The frame's time (camera pictures).
  std::vector<OverlayMark> marks;  ///< What was drawn where (output pixels).
};

struct SnapshotResult {
  std::vector<SnapshotPicture> pictures;
  std::vector<std::string> notes;           ///< What could not be drawn and why.
  std::vector<PoseComparison> comparisons;  ///< One per reference, in order.
};

/// Reads the dataset once and writes the pictures (each PNG atomically).
/// Throws lookboth::Error on unreadable input, StopRequested when stopped.
SnapshotResult writeSnapshots(const std::filesystem::path& dataset,
                              const RegistrationView& registration, const SnapshotOptions& options,
                              const ProgressReporter& progress);

/// "WxH" -> size; throws lookboth::Error naming '--size'.
cv::Size parseSize(const std::string& text);

}  // namespace lookboth::report
