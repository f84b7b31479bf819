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

/// The covariance of camera_from_node = camera_from_marker * marker_from_node,
/// given camera_from_marker's (marker_from_node held exact).
Matrix6d composedCovariance(const Rigid3d& camera_from_marker, const Rigid3d& marker_from_node,
                            const Matrix6d& camera_from_marker_covariance);

/// The trajectory's sample nearest `t` (the trajectory sorted by time, not
/// empty).
std::size_t nearestSample(const std::vector<StampedPose>& trajectory, TimeNs t);

/// A detection of the robot's marker by a camera as an edge from the camera
/// to the trajectory node nearest its time (robot clock: the camera's stamp
/// minus its clock offset): camera_from_marker * marker_from_fisheye *
/// fisheye_from_node (along the registered trajectory), with the
/// detection's covariance (its information inverted; `fallback` when it
/// has none). From the camera because a detection knows the marker's tilt
/// far worse than its position: inverted, over the camera's height as a
/// lever, the pose would no longer be Gaussian; from the camera the lever is
/// the marker's offset on the robot. nullopt outside the trajectory.
std::optional<PoseEdge> markerEdge(const Trajectory& trajectory, const MarkerObservation& detection,
                                   TimeNs clock_offset_ns, const Rigid3d& fisheye_from_marker,
                                   const Matrix6d& fallback);

/// How loose a blob edge is where a bearing says nothing: along the ray
/// and about every axis of the camera's rotation.
struct BlobEdgeLooseness {
  double along_ray_sigma_m = 10;
  double rotation_sigma_rad = 10;
};

/// A blob (a camera's housing in the fisheye frame at `blob.t`) as an edge
/// from the trajectory node nearest it to the camera: the bearing through
/// the pixel, at the registered distance, its sideways sigma from
/// `sigma_px` through the fisheye's model; along the ray and in rotation
/// the edge is loose (`looseness`), the registered values as its mean.
/// nullopt outside the trajectory or when the pixel has no ray.
std::optional<PoseEdge> blobEdge(const Trajectory& trajectory, const BlobAssociation& blob,
                                 const Camera& fisheye, const Rigid3d& world_from_camera,
                                 double sigma_px, const BlobEdgeLooseness& looseness = {});

/// The squared Mahalanobis distance between an edge and the relative pose of
/// its nodes as registered (right perturbation, 6 dof).
double edgeChi2(const PoseEdge& edge, const Rigid3d& first_from_second);

}  // namespace lookboth::export_detail
