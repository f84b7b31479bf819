// Test support: synthetic registration problems with exact ground truth
// (COLMAP-style: truth -> measurements -> noise -> solve -> bound), and
// accuracy of a registration against ground truth.
#pragma once
#include <random>
#include <string>
#include <vector>

#include "lookboth/calib/associate.h"
#include "lookboth/calib/problem.h"
#include "lookboth/registration/registration.h"

namespace lookboth::testing {

struct SyntheticOptions {
  int cameras = 6;
  double loop_length_m = 24;  ///< Rectangle 2:1 with rounded corners.
  double speed_mps = 0.6;
  double ceiling_m = 3.3;  ///< Camera height above the floor.
  double fisheye_height_m = 0.35;
  double height_amplitude_m = 0.02;       ///< The floor's undulation along the path.
  double marker_yaw_deg = 90.5;           ///< fisheye_from_marker's yaw (roll 0.4, pitch -0.3 deg).
  double roll_pitch_amplitude_deg = 0;    ///< Floor roll/pitch (0 = planar motion).
  double marker_translation_sigma_m = 0;  ///< Detection noise (isotropic, camera frame).
  double marker_rotation_sigma_deg = 0;
  double blob_sigma_px = 0;
  int laps = 1;
  double camera_rate_hz = 10;
  double fisheye_rate_hz = 20;
  double detection_radius_m = 2.0;
  std::uint32_t seed = 1;
};

struct SyntheticScene {
  RegistrationInput input;  ///< Markers, blobs, manifest (fisheye calibration), true trajectory.
  std::vector<StampedPose> truth;  ///< world_from_fisheye samples (the input trajectory).
  std::map<std::string, Rigid3d> world_from_camera;
  Rigid3d fisheye_from_marker;
};

/// A loop under a row of ceiling cameras. The input trajectory is the truth
/// (metric mode); the true continuous motion IS its linear+slerp interpolation,
/// so noise-free detections are exactly consistent.
SyntheticScene makeSyntheticScene(const SyntheticOptions& options);

/// Replaces the trajectory by a "visual odometry" one: expressed in the first
/// pose's frame, translations divided by `scale` (so the true metric scale is
/// `scale`), plus a random-walk drift of `drift_m_per_sqrt_m` (per sqrt metre
/// travelled) in position and `drift_deg_per_sqrt_m` in yaw. Returns the VO
/// world's pose in the true world (world_from_vo) at the first sample.
Rigid3d makeVisualOdometry(std::vector<StampedPose>& trajectory, double scale,
                           double drift_m_per_sqrt_m, double drift_deg_per_sqrt_m,
                           std::uint32_t seed);

/// The stages before `joint` on the scene's input: associate, motion
/// calibration (its mount prior at the scene's true fisheye_from_marker
/// translation), look_down.
RegistrationProblem stagesBeforeJoint(const SyntheticScene& scene,
                                      const AssociateOptions& associate = {});

struct Accuracy {
  double position_rmse_m = 0, position_max_m = 0;
  double rotation_rmse_deg = 0, rotation_max_deg = 0;
  int compared = 0;
};

/// Errors of the registered (and suspect) cameras against the truth, after
/// mapping the registration's world by `truth_from_registration` (identity
/// when the registration's world is the truth's).
Accuracy accuracyAgainst(const Registration& registration,
                         const std::map<std::string, Rigid3d>& world_from_camera,
                         const Rigid3d& truth_from_registration = Rigid3d());

/// The same after the best rigid (Umeyama SE(3)) alignment over camera positions.
Accuracy alignedAccuracy(const Registration& registration,
                         const std::map<std::string, Rigid3d>& world_from_camera);

}  // namespace lookboth::testing
