// A marker pose measurement's error as a perturbation of the camera's pose.
//
// A camera sees the marker at camera_from_marker = T. A measurement's error
// e = (dt, dtheta) in the convention of MarkerObservation (t_true = t + dt in
// the camera frame, R_true = R Exp(dtheta) with dtheta in the marker frame) is
// the same as moving the camera: camera_from_world -> (x -> Exp(phi) x + rho)
// after it, with
//   phi = R dtheta,  rho = dt + [t]x phi,   i.e. delta = (rho, phi) = J e,
//   J = [I, [t]x R; 0, R],  J^-1 = [I, -[t]x; 0, R^T].
// A bias a pass's detections share is such a perturbation; their information
// about it is sum J^-T I J^-1, in this one frame for all of them.
#pragma once

#include <Eigen/Core>

#include "lookboth/geometry/rigid3.h"

namespace lookboth {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

inline Eigen::Matrix3d skewMatrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

/// J: a marker measurement's error to the camera's pose perturbation.
inline Matrix6d cameraPerturbationFromMarkerError(const Rigid3d& camera_from_marker) {
  const Eigen::Matrix3d r = camera_from_marker.rotation.toRotationMatrix();
  Matrix6d j = Matrix6d::Zero();
  j.topLeftCorner<3, 3>().setIdentity();
  j.topRightCorner<3, 3>() = skewMatrix(camera_from_marker.translation) * r;
  j.bottomRightCorner<3, 3>() = r;
  return j;
}

/// J^-1: the camera's pose perturbation to the marker measurement's error.
inline Matrix6d markerErrorFromCameraPerturbation(const Rigid3d& camera_from_marker) {
  Matrix6d j_inverse = Matrix6d::Zero();
  j_inverse.topLeftCorner<3, 3>().setIdentity();
  j_inverse.topRightCorner<3, 3>() = -skewMatrix(camera_from_marker.translation);
  j_inverse.bottomRightCorner<3, 3>() = camera_from_marker.rotation.toRotationMatrix().transpose();
  return j_inverse;
}

/// A marker measurement's information (about e) as information about the
/// camera's pose perturbation: J^-T I J^-1.
inline Matrix6d informationOnCameraPose(const Rigid3d& camera_from_marker,
                                        const Matrix6d& information) {
  const Matrix6d j_inverse = markerErrorFromCameraPerturbation(camera_from_marker);
  return j_inverse.transpose() * information * j_inverse;
}

}  // namespace lookboth
