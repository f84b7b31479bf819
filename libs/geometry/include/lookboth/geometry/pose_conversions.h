// Every conversion between lookboth's Rigid3d and other representations
// lives here, so quaternion orders are decided in one place:
//
//   Eigen::Quaterniond      coeffs() = [x y z w]; constructor (w, x, y, z)
//   mrpt CPose3DQuat        [x y z qr qx qy qz]  (qr = w)
//   mrpt CPose3D / TPose3D  x y z yaw pitch roll (radians; its text uses degrees)
//   Ceres rotation.h        [w x y z]
//   TUM trajectory rows     tx ty tz qx qy qz qw
//
// An MRPT pose "of B in A" is a_from_b in lookboth's naming.
#pragma once

#include <mrpt/poses/CPose3D.h>
#include <mrpt/poses/CPose3DPDFGaussian.h>
#include <mrpt/poses/CPose3DQuat.h>
#include <Eigen/Geometry>

#include "lookboth/geometry/rigid3.h"

namespace lookboth {

Rigid3d fromMrptPose(const mrpt::poses::CPose3D& a_from_b);
mrpt::poses::CPose3D toMrptPose(const Rigid3d& a_from_b);

Rigid3d fromMrptPose(const mrpt::poses::CPose3DQuat& a_from_b);
mrpt::poses::CPose3DQuat toMrptPoseQuat(const Rigid3d& a_from_b);

/// A pose with its covariance over lookboth's [dt; dtheta] (doc/conventions.md:
/// t + dt, R Exp(dtheta)) as MRPT's PDF, whose covariance is over
/// [x y z yaw pitch roll] (the rotation block mapped through the derivative
/// of yaw, pitch and roll at the pose).
mrpt::poses::CPose3DPDFGaussian toMrptPosePdf(const Rigid3d& a_from_b,
                                              const Eigen::Matrix<double, 6, 6>& covariance);

Rigid3d fromIsometry(const Eigen::Isometry3d& a_from_b);
Eigen::Isometry3d toIsometry(const Rigid3d& a_from_b);

/// Ceres rotation.h order [w x y z].
void toCeresQuaternion(const Eigen::Quaterniond& q, double* wxyz);
Eigen::Quaterniond fromCeresQuaternion(const double* wxyz);

/// TUM order: [tx ty tz qx qy qz qw].
Eigen::Matrix<double, 7, 1> toTumVector(const Rigid3d& a_from_b);
/// From [tx ty tz qx qy qz qw]; the quaternion is normalised.
Rigid3d fromTumVector(const Eigen::Matrix<double, 7, 1>& tum);

}  // namespace lookboth
