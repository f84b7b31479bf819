// The result of `lookboth register`: the pose of every environment camera in
// the robot's world, the trajectory's metric scale, the robot's
// fisheye_from_marker, and what a technician needs to trust them
// (per-camera status and reason, covariances, residuals, statistics).
//
// On disk it is a directory (doc/formats.md, "Registration output"):
//   cameras.csv              label,tx,ty,tz,qx,qy,qz,qw   world_from_camera [m]
//   registration.yaml        everything below ("format: lookboth-registration 1")
//   trajectory.tum           the metric world_from_fisheye trajectory (after scaling)
//   blob_associations.csv    t_ns,camera,u,v,u_before,v_before,u_after,v_after
//   scene.3Dscene            written by the pipeline's output step, not by saveRegistration
//
// Covariances are over the perturbation [dt (m); dtheta (rad)] with
// t_true = t + dt and R_true = R * Exp(dtheta) (the dataset's MarkerObservation convention).
#pragma once
#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/time.h"
#include "lookboth/geometry/trajectory.h"

namespace lookboth {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

enum class CameraStatus {
  kRegistered,    ///< Pose estimated from consistent detections.
  kSuspect,       ///< Pose estimated, but the detections disagree or are few (see reason).
  kUnregistered,  ///< No pose (see reason).
};
/// "registered", "suspect", "unregistered".
const char* cameraStatusName(CameraStatus status);
/// Inverse of cameraStatusName; nullopt for anything else.
std::optional<CameraStatus> parseCameraStatus(const std::string& name);

/// How many marker detections a camera had and what became of them.
struct DetectionCounts {
  int total = 0;               ///< Detections of the robot's marker by this camera.
  int used = 0;                ///< Used in the final estimate.
  int rejected = 0;            ///< Associated but rejected as outliers.
  int outside_trajectory = 0;  ///< Dropped by the association (outside the trajectory or a gap).
};

/// RMS of the residuals of the looking-down estimate (inliers only).
struct ResidualStats {
  double position_rms_m = 0;
  double rotation_rms_deg = 0;
};

/// Fisheye reprojection of camera positions (stage 4, eq. 4-5) [px].
struct ReprojectionStats {
  int blobs = 0;             ///< Associated blob detections.
  double rms_px_before = 0;  ///< RMS before the refinement (look_down's position).
  double rms_px_after = 0;   ///< RMS after it.
  /// The stage whose estimate "after" is: "look_up", or "joint" (its
  /// corrected trajectory and cameras) when the pipeline ends with it.
  std::string after_stage = "look_up";
};

/// A camera's clock offset (node clock - robot clock) as estimated by the
/// `joint` stage.
struct ClockOffsetEstimate {
  TimeNs offset_ns = 0;
  double sigma_ms = 0;    ///< Its standard deviation [ms] (0 when not computed).
  bool estimated = true;  ///< false: held at the configured value.
};

struct CameraRegistration {
  std::string label;
  CameraStatus status = CameraStatus::kUnregistered;
  std::string reason;         ///< Why suspect/unregistered, in plain words; "" when registered.
  Rigid3d world_from_camera;  ///< Final pose; meaningless when unregistered.
  /// The pose after each stage that produced one, by stage name ("look_down", "look_up").
  std::map<std::string, Rigid3d> stage_poses;
  std::optional<Matrix6d> covariance;  ///< Of world_from_camera; absent when not computed.
  /// Its position's covariance once a rigid alignment over the registered
  /// cameras is projected out (joint's covariance, with the cross terms
  /// between cameras): what the aligned differences `lookboth evaluate`
  /// measures should show [m^2], in the registration's world axes. Absent
  /// unless joint computed it (aligned_uncertainty_max_cameras).
  std::optional<Eigen::Matrix3d> aligned_position_covariance;
  DetectionCounts detections;
  std::optional<ResidualStats> residuals;           ///< Absent when unregistered.
  std::optional<ReprojectionStats> reprojection;    ///< Absent when stage 4 did not run for it.
  std::optional<ClockOffsetEstimate> clock_offset;  ///< Absent unless `joint` ran.
  std::vector<std::string> warnings;                ///< What the technician should act on, and how.
  std::vector<std::string> notes;  ///< Worth knowing, nothing to do (outliers set aside...).
};

enum class TrajectoryMode {
  kVisual,  ///< Visual odometry up to scale (the paper): the scale is estimated.
  kMetric,  ///< A metric trajectory (LiDAR odometry, wheel+IMU, motion capture): scale 1.
};
/// "visual", "metric".
const char* trajectoryModeName(TrajectoryMode mode);
std::optional<TrajectoryMode> parseTrajectoryMode(const std::string& name);

/// One blob associated with a camera (stage 4): observed pixel and the
/// camera position projected into that fisheye frame before and after stage 4 [px].
struct BlobAssociation {
  TimeNs t = 0;  ///< Fisheye frame time (robot clock).
  std::string camera;
  double u = 0, v = 0;
  double u_before = 0, v_before = 0;
  double u_after = 0, v_after = 0;
};

/// The drift model joint estimated from the data (estimate_drift_model):
/// factors on the configured sigmas of the trajectory's relative motions.
struct DriftModelEstimate {
  double horizontal = 1;  ///< Translation in the body's x-y plane.
  double vertical = 1;    ///< Translation along the body's z.
  double tilt = 1;        ///< Roll and pitch.
  double yaw = 1;
  int updates = 0;  ///< Variance component estimates made (each followed by a round).
  /// The smooth motion between the input's samples (joint's
  /// between_samples_*): its velocity's and angular rate's random walks;
  /// only where nodes were added between them.
  std::optional<double> between_samples_velocity_walk, between_samples_rate_walk;
};

struct Observability {
  std::string message;              ///< Plain words: what the motion determines and what not.
  std::vector<double> eigenvalues;  ///< Of the motion calibration's information matrix, ascending.
  /// What the covariance predicts for the cameras' position RMSE after a
  /// rigid (SE(3)) alignment to any reference [m]: free of the gauge, which
  /// dominates each camera's own covariance (joint, when computed).
  std::optional<double> aligned_position_rmse_m;
  std::optional<DriftModelEstimate> drift_model;  ///< joint, with estimate_drift_model.
};

struct RegistrationStatistics {
  std::int64_t detections_total = 0;
  std::int64_t detections_associated = 0;
  std::int64_t dropped_outside_trajectory = 0;  ///< Before the first / after the last sample.
  std::int64_t dropped_gap = 0;                 ///< Inside a gap longer than the allowed maximum.
  std::map<std::string, double> seconds_per_stage;  ///< Wall time [s] by stage name.
  /// Wall time [s] of the steps `register` ran before the stages ("detect",
  /// "odometry"; absent when it did not run them), and the recording's span
  /// [s] (0: not known): what the run took against the drive it processed.
  std::map<std::string, double> seconds_per_step;
  double drive_seconds = 0;
};

/// Which frame a registration's poses are in (registration.yaml `world_frame`).
/// A surveyed point the site frame was fitted to, and how far the aligned
/// registration puts it (`lookboth align --control-points`).
struct ControlPointFit {
  std::string name;                                      ///< The camera's label.
  Eigen::Vector3d p_in_site = Eigen::Vector3d::Zero();   ///< Surveyed [m].
  Eigen::Vector3d residual_m = Eigen::Vector3d::Zero();  ///< Surveyed - registered [m].
  double sigmas = 0;  ///< |residual| over its predicted standard deviation.
};

struct WorldFrame {
  /// "registration": the first fisheye pose of the trajectory, as `register`
  /// writes it; "floor" or "site" once `lookboth align` re-expressed it.
  std::string name = "registration";
  std::string description = "the first fisheye pose of the trajectory";
  /// This frame from the registration's own, when re-expressed.
  std::optional<Rigid3d> from_registration;
  /// With from_registration: its scale (a Sim(3) site frame, `align
  /// --with-scale`: p = scale * (R p_registration) + t); 1 for a rigid one.
  double scale_from_registration = 1;
  /// "site" frames: the control points and their residuals, for the report.
  std::vector<ControlPointFit> control_points;
};

struct Registration {
  std::string dataset;                          ///< Absolute path of the dataset registered.
  std::string created;                          ///< UTC, ISO 8601 ("2026-11-22T12:00:00Z").
  std::map<std::string, std::string> versions;  ///< lookboth, mrpt, opencv, ceres.
  std::vector<std::string> pipeline;            ///< Stage names run, in order.

  TrajectoryMode trajectory_mode = TrajectoryMode::kVisual;
  std::string trajectory_label;  ///< The dataset trajectory used ("vo", "odometry", a file...).
  WorldFrame world_frame;        ///< Which frame every pose below is in.
  double scale = 1;              ///< Metric scale s of the trajectory (1 in metric mode).
  double scale_sigma = 0;        ///< Its standard deviation (0 when fixed).

  Rigid3d fisheye_from_marker;
  Matrix6d fisheye_from_marker_covariance = Matrix6d::Zero();
  /// Per component of [t; theta]: false when fixed by a prior rather than by the data.
  std::array<bool, 6> fisheye_from_marker_determined = {true, true, true, true, true, true};
  std::string fisheye_from_marker_prior;  ///< Which prior fixed what; "" when none.

  std::vector<CameraRegistration> cameras;
  std::optional<ReprojectionStats> reprojection;  ///< Totals over all cameras (stage 4).
  Observability observability;
  /// What the technician should act on, each saying how; they make the
  /// report's verdict "needs checking".
  std::vector<std::string> warnings;
  /// Worth knowing, nothing to act on: what a prior held because the data
  /// cannot determine it (expected on a flat floor), detections set aside
  /// at the ends of the trajectory, the solver's choices.
  std::vector<std::string> notes;
  RegistrationStatistics statistics;
  std::string config_yaml;  ///< The configuration used (YAML text of a map).

  std::vector<StampedPose> trajectory;  ///< Metric world_from_fisheye, after scaling.
  std::vector<BlobAssociation> blob_associations;

  const CameraRegistration* findCamera(const std::string& label) const;
  /// Cameras with status registered or suspect.
  int registeredCount() const;
  /// Its warnings, then each camera's prefixed by its label ("cam03: ...").
  std::vector<std::string> labelledWarnings() const;
  /// The same of its notes.
  std::vector<std::string> labelledNotes() const;
};

/// Writes cameras.csv, registration.yaml, trajectory.tum and
/// blob_associations.csv into `dir` (created if absent), each atomically.
/// Other files in `dir` (scene.3Dscene) are left alone.
void saveRegistration(const Registration& registration, const std::filesystem::path& dir);

/// What loadRegistration reads besides registration.yaml and the trajectory.
struct RegistrationLoadOptions {
  /// blob_associations.csv (a large facility's runs to 100,000 rows): a
  /// record that a check or an update compares cameras with needs none.
  bool blob_associations = true;
};

/// Reads a directory written by saveRegistration. Errors (lookboth::Error)
/// name the file, line and field.
Registration loadRegistration(const std::filesystem::path& dir,
                              const RegistrationLoadOptions& options = {});

/// The YAML text of registration.yaml.
std::string registrationToYaml(const Registration& registration);

/// A human-readable summary (for stdout): the result, one table row per
/// camera, then the warnings (what to act on). `verbose` adds the
/// observability statement and the notes.
std::string registrationSummary(const Registration& registration, bool verbose = false);

/// A line from a camera to a marker it detected (the paper's figure 1) [m, world].
struct DetectionRay {
  Eigen::Vector3d from;
  Eigen::Vector3d to;
};

struct RegistrationRun {
  Registration registration;
  std::vector<DetectionRay> rays;  ///< For the scene (inliers of look_down).
};

}  // namespace lookboth
