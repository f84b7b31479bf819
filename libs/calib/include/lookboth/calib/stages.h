// The paper's estimation stages (sections VI-VII of look-both-ways.tex), each
// an options struct (read from its section of the configuration, units in
// comments, check()) and a function on the shared RegistrationProblem. They
// are registered by name in StageRegistry::global():
//   associate           robot pose at each detection (linear + slerp, no extrapolation)
//   motion_calibration  scale s and fisheye_from_marker from relative motions (eq. 1-2)
//   look_down           world_from_camera per camera from its detections (eq. 3)
//   look_up             camera positions refined by fisheye reprojection of blobs (eq. 4-5)
#pragma once
#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>

#include "lookboth/calib/problem.h"
#include "lookboth/calib/stage.h"

namespace lookboth {

struct AssociateOptions {
  /// Largest interval between the two trajectory samples around a detection
  /// across which the pose is interpolated [s]; detections in longer gaps are dropped.
  double max_gap_s = 0.5;
  /// Known clock offsets, node clock minus robot clock, by camera label [ns]
  /// (0 when absent: NTP-synchronised nodes, as in the paper).
  std::map<std::string, TimeNs> clock_offsets_ns;
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  std::string check() const;
};

struct MotionCalibrationOptions {
  /// Two detections of one camera form a motion pair when they are this far apart in time [s].
  double min_pair_interval_s = 0.5;
  double max_pair_interval_s = 4.0;  ///< [s]
  /// Expected noise of one relative motion (translation [m], rotation [deg]);
  /// residuals are divided by them, so the Huber threshold is in sigmas.
  double sigma_translation_m = 0.01;
  double sigma_rotation_deg = 1.0;
  double huber = 2.0;  ///< Huber threshold [sigmas].
  /// Pairs that rotate less than this do not constrain the rotation axes in
  /// the linear initialisation [deg].
  double min_rotation_for_axis_deg = 5.0;
  /// A direction of the estimate whose standard deviation exceeds these is
  /// reported as not determined by the motion (translation [m], rotation [deg]).
  double max_translation_sigma_m = 0.01;
  double max_rotation_sigma_deg = 1.0;
  /// Measured fisheye_from_marker translation [m] (e.g. the marker's height
  /// below the fisheye with a tape); used only along directions the motion
  /// does not determine, with this sigma [m].
  std::optional<Eigen::Vector3d> prior_translation_m;
  double prior_translation_sigma_m = 0.005;
  /// Measured fisheye_from_marker rotation (x, y, z, w); used likewise.
  std::optional<Eigen::Quaterniond> prior_rotation;
  double prior_rotation_sigma_deg = 2.0;
  int max_iterations = 100;  ///< Ceres iterations.
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  std::string check() const;
};

struct LookDownOptions {
  /// Fewer associated detections than this: the camera is unregistered.
  int min_detections = 3;
  /// Fewer inliers than this: the camera is suspect (few detections).
  int suspect_min_detections = 8;
  /// More than this fraction of its detections rejected: the camera is suspect.
  double suspect_rejected_fraction = 0.3;
  double huber = 3.0;  ///< Huber threshold on the whitened residual [sigmas].
  /// A detection whose whitened squared residual exceeds this is rejected
  /// (chi-square, 6 degrees of freedom; 22.46 = 99.9 %).
  double reject_chi2 = 22.46;
  /// Uncertainty of the interpolated robot pose (drift, interpolation,
  /// clocks), added to every detection's covariance [m], [deg].
  double robot_position_sigma_m = 0.01;
  double robot_rotation_sigma_deg = 0.3;
  /// Marker pose noise for detections without an information matrix [m], [deg].
  double default_translation_sigma_m = 0.01;
  double default_rotation_sigma_deg = 2.0;
  /// Initial guess: the detection whose camera pose agrees with most others
  /// within this distance [m].
  double consensus_radius_m = 0.25;
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  std::string check() const;
};

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
  double max_gap_s = 0.5;  ///< Trajectory gap limit for fisheye frames [s].
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  std::string check() const;
};

void runAssociate(RegistrationProblem& problem, const AssociateOptions& options,
                  const ProgressReporter& progress);
void runMotionCalibration(RegistrationProblem& problem, const MotionCalibrationOptions& options,
                          const ProgressReporter& progress);
void runLookDown(RegistrationProblem& problem, const LookDownOptions& options,
                 const ProgressReporter& progress);
void runLookUp(RegistrationProblem& problem, const LookUpOptions& options,
               const ProgressReporter& progress);

/// Adds associate, motion_calibration, look_down, look_up to a registry.
void registerPaperStages(StageRegistry& registry);

}  // namespace lookboth
