// `lookboth evaluate`: how far a registration's camera poses are from ground
// truth, or from another registration (the paper's Table II), and the
// fisheye reprojection RMSE before and after the looking-up refinement (the
// paper's Table I).
//
// Both comparisons are the same operation: the estimate's camera positions
// are aligned onto the reference's by Umeyama (SE(3), or Sim(3) when the
// scale is free) over the cameras both have, then every camera's difference
// is measured in the reference's world frame:
//
//     reference_from_estimate = argmin sum_k || p_ref_k - T * p_est_k ||^2
//     est_k' = reference_from_estimate.transformPose(world_from_camera_est_k)
//     d_position_k = p(est_k') - p(ref_k)                       [m], reference world axes
//     d_rotation_k = R(est_k') * R(ref_k)^T = Rz(yaw) Ry(pitch) Rx(roll)   (world axes)
//     rotation error_k = angle of d_rotation_k                  [deg]
//
// Roll, pitch and yaw are thus the rotation differences about the world's x,
// y and z (vertical) axes; per-axis RMS values over the cameras are the
// columns of the paper's Table II.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/sim3.h"
#include "lookboth/geometry/time.h"

namespace lookboth {
struct Registration;
}

namespace lookboth::report {

/// Camera poses from one source (a registration, ground truth...).
struct CameraPoseSet {
  std::string source;  ///< Where they came from, for messages and reports.
  /// world_from_camera of every camera that has a pose.
  std::map<std::string, Rigid3d> world_from_camera;
  /// Cameras the source knows but could not give a pose for (status
  /// unregistered in a registration).
  std::vector<std::string> without_pose;
  /// A registration's predicted covariance of each camera's position after
  /// a rigid alignment (CameraRegistration::aligned_position_covariance),
  /// where it has one [m^2].
  std::map<std::string, Eigen::Matrix3d> aligned_position_covariance;
};

/// Reads `label,tx,ty,tz,qx,qy,qz,qw` (world_from_camera, metres, Hamilton
/// quaternion; the header may list the columns in any order; `#` lines and
/// blank lines are skipped). Errors name the file, the line and the column: a
/// missing column, a short row, a bad or non-finite number, a quaternion whose
/// norm is off 1 by more than 1e-3 (smaller deviations are normalised), a
/// duplicated label.
CameraPoseSet readCamerasCsv(const std::filesystem::path& path);

/// Ground truth camera poses from a dataset (a .rawlog or its manifest: the
/// manifest's ground_truth.world_from_camera), a dataset folder
/// (ground_truth/cameras.csv), or a cameras.csv file. Throws lookboth::Error
/// naming the path when there is no ground truth there.
CameraPoseSet loadGroundTruthPoses(const std::filesystem::path& path);

struct CompareOptions {
  /// Align with a similarity (Sim(3)) instead of a rigid transform: for an
  /// estimate whose scale is not metric.
  bool with_scale = false;
  std::string check() const { return {}; }
};

/// One camera's difference, estimate (aligned) minus reference.
struct CameraDifference {
  std::string label;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  ///< dx, dy, dz [m], reference world axes.
  double position_error_m = 0;                           ///< |position_m|.
  Eigen::Vector3d roll_pitch_yaw_deg = Eigen::Vector3d::Zero();  ///< About world x, y, z [deg].
  double rotation_error_deg = 0;  ///< Angle of the rotation difference [deg].
};

/// Root mean square over cameras of each component of CameraDifference.
struct DifferenceRms {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();          ///< RMS of dx, dy, dz [m].
  Eigen::Vector3d roll_pitch_yaw_deg = Eigen::Vector3d::Zero();  ///< RMS of droll, dpitch, dyaw.
  double position_m_total = 0;    ///< RMS of the position error norms [m].
  double rotation_deg_total = 0;  ///< RMS of the rotation angles [deg].
  double position_m_max = 0;      ///< Largest position error [m].
  double rotation_deg_max = 0;    ///< Largest rotation error [deg].
};

struct PoseComparison {
  std::string reference_source;
  std::string estimate_source;
  bool with_scale = false;
  Sim3d reference_from_estimate;  ///< The alignment (scale 1 unless with_scale).
  /// Cameras both have, in label order.
  std::vector<CameraDifference> cameras;
  DifferenceRms rms;
  /// Normalised estimation error squared of the positions per degree of
  /// freedom: the mean over cameras of d^T S^-1 d / 3, d the aligned
  /// difference and S the estimate's aligned_position_covariance turned into
  /// the reference's axes. Near 1 when the predicted uncertainty is honest;
  /// absent unless every common camera has a covariance, the alignment is
  /// rigid and the reference has no covariance of its own (ground truth). It treats the cameras as
  /// independent (each its own block of the aligned covariance), and is exact for the alignment
  /// only when the common cameras are the registration's aligned ones.
  std::optional<double> position_nees_per_dof;
  /// Reference cameras the estimate has no pose for (unregistered or
  /// absent): listed, not counted in the RMS.
  std::vector<std::string> missing_in_estimate;
  /// Estimate cameras the reference does not know (not counted either).
  std::vector<std::string> missing_in_reference;
};

/// Aligns `estimate` onto `reference` over their common cameras and measures
/// the differences. Throws lookboth::Error when fewer than 3 cameras are
/// common or their positions are collinear (the alignment is then not
/// determined), naming both sources.
PoseComparison comparePoses(const CameraPoseSet& reference, const CameraPoseSet& estimate,
                            const CompareOptions& options = {});

/// Fisheye reprojection of the camera positions (Table I): one row per
/// associated blob, observed pixel and the camera's position projected
/// before and after the looking-up refinement.
struct ReprojectionRow {
  TimeNs t = 0;  ///< Fisheye frame time.
  std::string camera;
  double u = 0, v = 0;
  std::optional<Eigen::Vector2d> before, after;  ///< nullopt when it did not project.
};

struct ReprojectionSummary {
  int blobs = 0;             ///< Rows counted.
  int blobs_before = 0;      ///< Rows with a projection before.
  int blobs_after = 0;       ///< Rows with a projection after.
  double rms_px_before = 0;  ///< RMS of |(u,v) - before| [px].
  double rms_px_after = 0;   ///< RMS of |(u,v) - after| [px].
  double max_px_before = 0;
  double max_px_after = 0;
};

struct ReprojectionTable {
  ReprojectionSummary total;
  std::map<std::string, ReprojectionSummary> by_camera;
};

ReprojectionTable reprojectionTable(const std::vector<ReprojectionRow>& rows);

/// `lookboth evaluate`'s output: any of the three parts may be absent.
struct Evaluation {
  std::string registration;  ///< The registration directory evaluated.
  std::optional<PoseComparison> ground_truth;
  std::optional<PoseComparison> against;
  std::optional<ReprojectionTable> reprojection;
  /// Per-camera reprojection figures reported by the registration itself
  /// (registration.yaml), for comparison with the recomputed table.
  std::optional<ReprojectionSummary> reported_reprojection;
};

/// Registered and suspect cameras' poses of a registration; unregistered
/// cameras go to without_pose.
CameraPoseSet poseSetOfRegistration(const Registration& registration, const std::string& source);

/// Stage 4's blob associations as reprojection rows (a non-finite
/// projection becomes nullopt).
std::vector<ReprojectionRow> reprojectionRows(const Registration& registration);

struct EvaluateOptions {
  std::filesystem::path ground_truth;  ///< Dataset, dataset folder or cameras.csv; empty = none.
  std::filesystem::path against;       ///< Another registration directory; empty = none.
  bool with_scale = false;             ///< Sim(3) alignment (scale free) instead of SE(3).
  std::string check() const;
};

/// Loads the registration in `registration_dir` (loadRegistration) and
/// evaluates it: against ground truth, against another registration, and
/// its reprojection table (when it has blob associations).
Evaluation evaluateRegistration(const std::filesystem::path& registration_dir,
                                const EvaluateOptions& options);

/// evaluation.json text (doc/formats.md, "evaluation.json").
std::string evaluationToJson(const Evaluation& evaluation);
/// Writes evaluation.json atomically.
void writeEvaluationJson(const Evaluation& evaluation, const std::filesystem::path& path);

/// Human-readable tables for the terminal: per camera, RMS, Table II row,
/// Table I.
std::string formatComparisonTable(const PoseComparison& comparison, const std::string& title);
std::string formatTableTwoRow(const PoseComparison& comparison, const std::string& row_name);
std::string formatReprojectionTable(const ReprojectionTable& table);

}  // namespace lookboth::report
