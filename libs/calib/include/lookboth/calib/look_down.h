// The stage "look_down" (the paper's eq. 3): world_from_camera of each camera
// from its marker detections, information-weighted, outliers rejected, with
// its covariance.
#pragma once
#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>

#include "lookboth/calib/problem.h"
#include "lookboth/calib/stage_registry.h"

namespace lookboth {

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
  /// Sets the options `node` (the configuration's "register.<stage>" section,
  /// named `field` in errors) has; an unknown key is an error.
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  /// Every option under its key, as read() reads them.
  void write(YAML::Node& node) const;
  std::string check() const;
};

void runLookDown(RegistrationProblem& problem, const LookDownOptions& options,
                 const ProgressReporter& progress);

}  // namespace lookboth
