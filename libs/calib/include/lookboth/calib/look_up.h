// The stage "look_up" (the paper's eq. 4-5): camera positions refined by the
// fisheye's reprojection of the camera housings it sees (blobs).
#pragma once
#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>

#include "lookboth/calib/problem.h"
#include "lookboth/calib/stage_registry.h"

namespace lookboth {

struct LookUpOptions {
  /// A camera's projection is associated with the nearest blob within this distance [px]...
  double gate_px = 25;
  /// After the first round, each camera's gate is 4x its RMS, at least this [px].
  double min_gate_px = 5;
  /// ...when the second nearest blob is at least this many times farther, and no
  /// other camera projects that close to the blob (ambiguity test, both ways).
  double ambiguity_ratio = 1.5;
  double cauchy_px = 2.0;  ///< Cauchy loss scale [px].
  int rounds = 2;          ///< Association + solve rounds.
  /// Blob residuals per camera in the solve, evenly spread in time (0 = all);
  /// the statistics use every associated blob.
  int max_blobs_per_camera = 500;
  /// The rounds associate blobs of every n-th fisheye frame; the final
  /// association (statistics, blob_associations.csv) uses every frame.
  int association_frame_step = 3;
  int min_blobs = 5;  ///< Fewer associated blobs: the camera keeps its look_down position.
  /// Largest move of a camera by this stage [m]; a larger one is refused (warning).
  double max_shift_m = 0.5;
  /// Where the blob's centre is in the camera frame [m]: the simulator's
  /// housing dome is centred on the optical centre (0,0,0); a real housing
  /// whose visible centre is above the lens sets e.g. [0, 0, -0.05].
  Eigen::Vector3d blob_offset_in_camera_m = Eigen::Vector3d::Zero();
  double max_gap_s = 0.5;  ///< Trajectory gap limit for fisheye frames [s] (as associate's).
  /// Sets the options `node` (the configuration's "register.<stage>" section,
  /// named `field` in errors) has; an unknown key is an error.
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  /// Every option under its key, as read() reads them.
  void write(YAML::Node& node) const;
  std::string check() const;
};

void runLookUp(RegistrationProblem& problem, const LookUpOptions& options,
               const ProgressReporter& progress);

}  // namespace lookboth
