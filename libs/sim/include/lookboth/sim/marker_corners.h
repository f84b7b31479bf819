// --detections-only with `noise.marker_corners: true` (doc/formats.md,
// "Scenario files"): the marker's four corners as a detector finds them
// (true projections + iid Gaussian pixel noise) and the pose a detector
// computes from them, so that a dataset carries both, consistently.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <random>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/records.h"
#include "lookboth/geometry/rigid3.h"

namespace lookboth::sim {

/// The corners of a square marker of side `size_m` in its own frame [m], in
/// MarkerObservation's corner order: (-s/2, s/2, 0), (s/2, s/2, 0),
/// (s/2, -s/2, 0), (-s/2, -s/2, 0).
std::array<Eigen::Vector3d, 4> markerCornersInMarker(double size_m);

struct CornerPose {
  Rigid3d camera_from_marker;
  /// J^T J / sigma^2 at the solution, over MarkerObservation's perturbation
  /// [dt (m); dtheta (rad)] (t_true = t + dt, R_true = R Exp(dtheta)).
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  double reprojection_rms_px = 0;  ///< Over the 4 corners.
};

/// Pose of a square marker from its 4 corners [px]: Gauss-Newton on the
/// pixel reprojection error through `camera`'s model, from `initial`
/// (which must be close: there is no global search). `corner_sigma_px` (> 0)
/// scales the information. nullopt when a corner does not project or the
/// iteration does not converge.
std::optional<CornerPose> poseFromCorners(const Camera& camera, double size_m,
                                          const std::array<Eigen::Vector2d, 4>& corners_px,
                                          const Rigid3d& initial, double corner_sigma_px);

/// A MarkerObservation as a corner-based detector makes it: corners = the
/// true projections of `camera_from_marker`'s corners + N(0, sigma^2) per
/// coordinate (8 draws from `rng`), pose and information by poseFromCorners
/// started at the truth, corner_sigma_px = sigma. `t` and `camera` are left
/// to the caller. sigma = 0 gives the exact pose (its information is then
/// computed with sigma = 1e-6 px). nullopt when a corner does not project.
std::optional<MarkerObservation> markerFromNoisyCorners(const Camera& camera,
                                                        const Rigid3d& camera_from_marker,
                                                        const MarkerSpec& marker,
                                                        double corner_sigma_px, std::mt19937& rng);

/// The bias a pass's detections share (DetectionNoiseSpec::marker_pass_share):
/// one perturbation delta of the camera's pose (geometry/pose_perturbation.h)
/// drawn from N(0, share n D^-1), n the detections, D the sum of their
/// informations about it (6 draws from `rng`), applied to each as a camera
/// would move (camera_from_marker -> Exp(phi) R, Exp(phi) t + rho); their
/// corners, when they have them and `camera` is given, move with its
/// projection of the marker's corners (`marker_size_m`). The pass's weighted
/// mean error then has NEES 6 (1 + share n) on average.
void addPassBias(const std::vector<MarkerObservation*>& pass, double share, std::mt19937& rng,
                 const Camera* camera, double marker_size_m);

}  // namespace lookboth::sim
