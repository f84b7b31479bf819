// The measurements behind MRPT's pose graph (mrpt.cpp), each as an edge
// between two of its nodes: a relative pose and its 6x6 covariance over
// [dt (m); dtheta (rad)] with t_true = t + dt, R_true = R Exp(dtheta)
// (doc/conventions.md), in the frame of the edge's first node.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/dataset/records.h"
#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/trajectory.h"
#include "lookboth/registration/registration.h"

namespace lookboth::export_detail {

/// An edge between a trajectory node and a camera: the measured pose of the
/// second in the first, either way round.
struct PoseEdge {
  std::size_t node = 0;      ///< The trajectory node.
  bool from_camera = false;  ///< The edge goes camera -> node (else node -> camera).
  Rigid3d first_from_second;
  Matrix6d covariance = Matrix6d::Identity();
};

/// How the registration modelled its measurements, as the edges need it.
struct EdgeModel {
  /// Longest trajectory gap a measurement may be interpolated across: the
  /// effectiveMaxGap of associate.max_gap_s on the registered trajectory [ns].
  TimeNs max_gap_ns = 500'000'000;
  Rigid3d fisheye_from_marker;
  /// A detection without an information matrix: this covariance.
  Matrix6d default_detection_covariance = Matrix6d::Identity() * 1e-4;
  double blob_sigma_px = 1.0;  ///< A blob centre's noise [px].
  /// Where a blob is on its camera (the housing's centre), in the camera's
  /// frame (joint.blob_offset_in_camera_m) [m].
  Eigen::Vector3d blob_in_camera = Eigen::Vector3d::Zero();
  /// How loose a blob edge is where a bearing says nothing: along the ray
  /// [m] and about every axis of the camera's rotation [rad].
  double blob_along_ray_sigma_m = 10;
  double blob_rotation_sigma_rad = 10;
};

/// The covariance of camera_from_node = camera_from_marker * marker_from_node,
/// given camera_from_marker's (marker_from_node held exact).
Matrix6d composedCovariance(const Rigid3d& camera_from_marker, const Rigid3d& marker_from_node,
                            const Matrix6d& camera_from_marker_covariance);

/// The trajectory's sample nearest `t` (the trajectory sorted by time, not
/// empty).
std::size_t nearestSample(const std::vector<StampedPose>& trajectory, TimeNs t);

/// A detection of the robot's marker by a camera as an edge from the camera
/// to the trajectory node nearest its time (robot clock: the camera's stamp
/// minus its clock offset, node - robot): camera_from_marker *
/// marker_from_fisheye * fisheye_from_node (along the registered
/// trajectory), with the detection's covariance (markerCovariance, else the
/// model's default). From the camera because a detection knows the marker's
/// tilt far worse than its position: inverted, over the camera's height as a
/// lever, the pose would no longer be Gaussian; from the camera the lever is
/// the marker's offset on the robot. nullopt outside the trajectory or in
/// one of its gaps.
std::optional<PoseEdge> markerEdge(const Trajectory& trajectory, const MarkerObservation& detection,
                                   TimeNs clock_offset_ns, const EdgeModel& model);

/// A blob (a camera's housing in the fisheye frame at `blob.t`) as an edge
/// from the trajectory node nearest it to the camera: the housing on the
/// bearing through the pixel at its registered distance, the camera's
/// centre behind it by blob_in_camera, sideways the pixel's noise through
/// the fisheye's model; along the ray and in rotation the edge is loose, the
/// registered values its mean. nullopt outside the trajectory, in a gap, or
/// when the pixel has no ray.
std::optional<PoseEdge> blobEdge(const Trajectory& trajectory, const BlobAssociation& blob,
                                 const Camera& fisheye, const Rigid3d& world_from_camera,
                                 const EdgeModel& model);

/// For each of a camera's measurement times (sorted), the size of its pass:
/// the run of times with no gap over `max_gap_ns` that holds it.
std::vector<int> passSizes(const std::vector<TimeNs>& sorted_times, TimeNs max_gap_ns);

/// The factor on a measurement's covariance that gives a pass of `n`
/// independent edges the variance of a mean whose errors share `share`
/// (equicorrelated: (1 + share (n - 1)) / n of one's): what a graph without
/// correlations can carry of the joint's shared pass errors.
inline double passInflation(int n, double share) { return 1 + share * (n - 1); }

/// Edges between the same two nodes, all the same way round, as one (MRPT
/// keeps a single edge per pair of nodes): their information summed, the
/// mean moved from the first by the information-weighted mean of their
/// differences from it (to first order).
PoseEdge fuseEdges(const std::vector<PoseEdge>& edges);

/// The squared Mahalanobis distance between an edge and the relative pose of
/// its nodes as registered (right perturbation, 6 dof).
double edgeChi2(const PoseEdge& edge, const Rigid3d& first_from_second);

}  // namespace lookboth::export_detail
