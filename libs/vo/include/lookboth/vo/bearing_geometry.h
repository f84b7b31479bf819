// Two-view and absolute geometry on unit bearing vectors (central cameras of
// any field of view, including fisheyes beyond 180 deg): RANSAC around
// OpenGV's minimal solvers (Nister's five-point, Kneip's P3P), non-linear
// refinement on the inliers, triangulation, and the tangent-plane residual
// shared by every adjustment of the module.
//
// Angular errors are measured between unit bearings [rad]; RANSAC thresholds
// are angles too (a pixel threshold divided by the camera's focal length in
// pixels per radian).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "lookboth/geometry/rigid3.h"

namespace lookboth::vo {

using Bearings = std::vector<Eigen::Vector3d>;

struct RansacOptions {
  double threshold_rad = 0.005;  ///< Inlier if the angular error is below this [rad].
  int max_iterations = 500;      ///< Upper bound on hypotheses.
  double confidence = 0.999;     ///< Stops early once this confident of the best set.
  std::uint32_t seed = 1;        ///< Random sampling seed (results are deterministic for a seed).
};

struct RelativePoseResult {
  /// Pose of view 2 in view 1: bearing1 ~ cam1_from_cam2 * X_in_cam2. |translation| = 1.
  Rigid3d cam1_from_cam2;
  std::vector<bool> inliers;  ///< One per correspondence.
  int num_inliers = 0;
};

/// Relative pose from >= 5 bearing correspondences (five-point + RANSAC, then
/// a non-linear refinement on the inliers). nullopt when no model has at
/// least 5 inliers. Handles planar scenes (five-point is not degenerate on a
/// plane); pure rotation gives an arbitrary translation direction, which the
/// caller detects by the triangulation angles.
std::optional<RelativePoseResult> estimateRelativePose(const Bearings& bearings1,
                                                       const Bearings& bearings2,
                                                       const RansacOptions& options);

struct AbsolutePoseResult {
  Rigid3d world_from_camera;
  std::vector<bool> inliers;
  int num_inliers = 0;
};

/// Absolute pose from >= 4 bearing/point correspondences (P3P + RANSAC, then
/// a non-linear refinement on the inliers).
std::optional<AbsolutePoseResult> estimateAbsolutePose(
    const Bearings& bearings_in_camera, const std::vector<Eigen::Vector3d>& p_in_world,
    const RansacOptions& options);

/// Angular error between a bearing and the direction of a point in the camera [rad].
double angularError(const Eigen::Vector3d& bearing, const Eigen::Vector3d& p_in_camera);

/// Point nearest to both rays (midpoint method). nullopt when the rays are
/// closer than `min_angle_rad` to parallel or the point is behind either view.
std::optional<Eigen::Vector3d> triangulateMidpoint(const Rigid3d& world_from_a,
                                                   const Eigen::Vector3d& bearing_a,
                                                   const Rigid3d& world_from_b,
                                                   const Eigen::Vector3d& bearing_b,
                                                   double min_angle_rad);

/// Two unit vectors spanning the plane orthogonal to a unit bearing (rows of
/// the returned matrix); residuals of the adjustments are the components of
/// the predicted unit direction along them, ~ the angular error in radians
/// for small errors, and well defined at any incidence angle.
Eigen::Matrix<double, 2, 3> tangentBasis(const Eigen::Vector3d& bearing);

}  // namespace lookboth::vo
