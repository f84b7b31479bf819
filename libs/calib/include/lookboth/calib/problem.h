// The shared state of a registration: what the estimation stages read and
// write. A stage (lookboth/calib/stage_registry.h) takes a RegistrationProblem, checks
// that what it needs is there (e.g. look_down needs fisheye_from_marker) and
// adds its results; the controller (lookboth/pipeline/registration_controller.h) only runs stages
// in order.
//
// Frames (doc/conventions.md): the trajectory is world_from_fisheye, up to
// the metric scale `scale` in visual mode: the metric pose is
//     world_from_fisheye_metric = (R, scale * t).
// Detections are stamped in their camera's clock; association converts them
// to the robot's clock with the configured clock offsets (node - robot).
#pragma once
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/records.h"
#include "lookboth/geometry/trajectory.h"
#include "lookboth/registration/registration.h"

namespace lookboth {

/// What a registration starts from. Stages may add to it (a future `detect`
/// stage fills `markers` and `blobs` from images, `odometry` the trajectory).
struct RegistrationInput {
  std::filesystem::path dataset;  ///< Absolute path of the dataset ("" for synthetic input).
  Manifest manifest;
  std::vector<MarkerObservation> markers;  ///< Marker detections (camera clocks).
  std::vector<BlobObservation> blobs;      ///< Blobs in fisheye frames (robot clock).
  Trajectory trajectory;                   ///< world_from_fisheye, robot clock.
  TrajectoryMode mode = TrajectoryMode::kVisual;
  std::string trajectory_label;  ///< Dataset label or file the trajectory came from.
};

/// One marker detection with the robot pose at its time.
struct Association {
  std::size_t marker_index = 0;  ///< Into RegistrationInput::markers.
  TimeNs t_robot = 0;            ///< Detection time in the robot's clock.
  Rigid3d world_from_fisheye;    ///< Interpolated, UNSCALED (trajectory units).
};

/// A camera held near a registration on record (`register --update`,
/// lookboth/calib/record_update.h): its pose there, in the record's frame, and
/// that pose's covariance ([dt; dtheta], doc/conventions.md) as the prior's weight.
struct CameraPrior {
  Rigid3d world_from_camera;
  Matrix6d covariance = Matrix6d::Identity();
};

struct RegistrationProblem {
  RegistrationInput input;

  /// Priors on cameras' poses (by label), for `joint`: when any is set the
  /// world is the frame they are in (the record's), not the first fisheye
  /// pose, and the trajectory and the other cameras must start in it.
  std::map<std::string, CameraPrior> camera_priors;

  // --- associate ---
  bool associated = false;
  std::vector<Association> associations;
  /// Indices into `associations`, by camera label, in time order.
  std::map<std::string, std::vector<std::size_t>> associations_by_camera;

  // --- motion calibration (or a prior) ---
  double scale = 1.0;  ///< Metric scale of the trajectory.
  std::optional<Rigid3d> fisheye_from_marker;

  /// Detections (indices into `associations`) each camera's pose rests on,
  /// by camera label (look_down's inliers).
  std::map<std::string, std::vector<std::size_t>> inliers_by_camera;

  /// The metric world_from_fisheye trajectory when a stage corrected it
  /// (`joint`); absent: the input trajectory scaled by `scale`.
  std::optional<std::vector<StampedPose>> metric_trajectory;

  /// The result being built: cameras, statistics, warnings, diagnostics.
  /// Stages write `result.cameras[...]`, `result.fisheye_from_marker*`,
  /// `result.observability`, `result.warnings`, `result.reprojection`.
  Registration result;

  /// Metric world_from_fisheye of an association (scale applied).
  Rigid3d metricWorldFromFisheye(const Rigid3d& unscaled) const {
    return Rigid3d(unscaled.rotation, scale * unscaled.translation);
  }
  /// The camera's entry in `result.cameras`, created (unregistered) if absent.
  CameraRegistration& camera(const std::string& label);
  const MarkerObservation& marker(const Association& a) const {
    return input.markers[a.marker_index];
  }
};

}  // namespace lookboth
