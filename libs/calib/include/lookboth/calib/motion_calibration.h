// The stage "motion_calibration" (the paper's eq. 1-2): the trajectory's
// metric scale s and fisheye_from_marker from relative motions of the robot
// and of the marker seen by each camera, with what the motion determines and
// priors for the rest.
#pragma once
#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>

#include "lookboth/calib/problem.h"
#include "lookboth/calib/stage_registry.h"

namespace lookboth {

struct MotionCalibrationOptions {
  /// Two detections of one camera form a motion pair when they are this far apart in time [s].
  double min_pair_interval_s = 0.5;
  double max_pair_interval_s = 4.0;  ///< [s]
  /// Expected noise of one relative motion (translation [m], rotation [deg]);
  /// residuals are divided by them, so the Huber threshold is in sigmas.
  double sigma_translation_m = 0.01;
  double sigma_rotation_deg = 0.5;
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
  /// true: the translation of B is the marker's displacement in the camera
  /// frame mapped by the marker orientation predicted from the camera's
  /// orientation averaged over all its detections (beyond the paper: removes
  /// the bias that one detection's tilt noise puts on the scale); false: the
  /// paper's B = M_i^-1 M_j.
  bool translation_from_camera_orientation = true;
  /// Sets the options `node` (the configuration's "register.<stage>" section,
  /// named `field` in errors) has; an unknown key is an error.
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  /// Every option under its key, as read() reads them.
  void write(YAML::Node& node) const;
  std::string check() const;
};

void runMotionCalibration(RegistrationProblem& problem, const MotionCalibrationOptions& options,
                          const ProgressReporter& progress);

}  // namespace lookboth
