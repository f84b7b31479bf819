// Exponential and logarithm maps of SO(3) and SE(3), templated for Ceres.
//
// Tangent vectors:
//  - so(3): omega (3), the rotation vector (axis * angle, radians).
//  - se(3): [upsilon (3); omega (3)] — translational part first, as in
//    Sophus. This is the true SE(3) log (translation goes through V(omega)),
//    not MRPT's pseudo-log, which passes the translation through unchanged.
//
// Perturbations are on the left unless a function says otherwise:
// boxMinus(a, b) = log(a * b^-1) is small when a ~= b, expressed in a's
// outer frame.
#pragma once

#include <cmath>

#include "lookboth/geometry/rigid3.h"

namespace lookboth {

/// Rotation of a rotation vector. Exact near zero (Taylor branch).
template <typename T>
Eigen::Quaternion<T> so3Exp(const Eigen::Matrix<T, 3, 1>& omega) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T theta_squared = omega.squaredNorm();
  if (theta_squared > T(1e-12)) {
    const T theta = sqrt(theta_squared);
    const T half = theta / T(2);
    const T k = sin(half) / theta;
    return Eigen::Quaternion<T>(cos(half), k * omega.x(), k * omega.y(), k * omega.z());
  }
  // sin(theta/2)/theta = 1/2 - theta^2/48 + O(theta^4); cos(theta/2) = 1 - theta^2/8.
  const T k = T(0.5) - theta_squared / T(48);
  return Eigen::Quaternion<T>(T(1) - theta_squared / T(8), k * omega.x(), k * omega.y(),
                              k * omega.z())
      .normalized();
}

/// Rotation vector of a unit quaternion, angle in [0, pi].
template <typename T>
Eigen::Matrix<T, 3, 1> so3Log(const Eigen::Quaternion<T>& q_in) {
  using std::atan2;
  using std::sqrt;
  // Use the representative with w >= 0 so that the angle is at most pi.
  Eigen::Quaternion<T> q = q_in;
  if (q.w() < T(0)) q.coeffs() = -q.coeffs();
  const Eigen::Matrix<T, 3, 1> v = q.vec();
  const T sin_half_squared = v.squaredNorm();
  if (sin_half_squared > T(1e-12)) {
    const T sin_half = sqrt(sin_half_squared);
    const T theta = T(2) * atan2(sin_half, q.w());
    return (theta / sin_half) * v;
  }
  // theta / sin(theta/2) ~= 2 / w * (1 + sin_half^2 / (3 w^2)).
  const T w = q.w();
  return (T(2) / w) * (T(1) + sin_half_squared / (T(3) * w * w)) * v;
}

template <typename T>
Eigen::Matrix<T, 3, 3> skew(const Eigen::Matrix<T, 3, 1>& v) {
  Eigen::Matrix<T, 3, 3> m;
  m << T(0), -v.z(), v.y(), v.z(), T(0), -v.x(), -v.y(), v.x(), T(0);
  return m;
}

/// Left Jacobian of SO(3), V(omega) = I + (1-cos t)/t^2 W + (t - sin t)/t^3 W^2.
template <typename T>
Eigen::Matrix<T, 3, 3> so3LeftJacobian(const Eigen::Matrix<T, 3, 1>& omega) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const Eigen::Matrix<T, 3, 3> W = skew(omega);
  const T theta_squared = omega.squaredNorm();
  T a, b;
  if (theta_squared > T(1e-8)) {
    const T theta = sqrt(theta_squared);
    a = (T(1) - cos(theta)) / theta_squared;
    b = (theta - sin(theta)) / (theta_squared * theta);
  } else {
    a = T(0.5) - theta_squared / T(24);
    b = T(1) / T(6) - theta_squared / T(120);
  }
  return Eigen::Matrix<T, 3, 3>::Identity() + a * W + b * W * W;
}

/// Inverse of the left Jacobian of SO(3).
template <typename T>
Eigen::Matrix<T, 3, 3> so3LeftJacobianInverse(const Eigen::Matrix<T, 3, 1>& omega) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const Eigen::Matrix<T, 3, 3> W = skew(omega);
  const T theta_squared = omega.squaredNorm();
  T c;
  if (theta_squared > T(1e-8)) {
    const T theta = sqrt(theta_squared);
    c = (T(1) - theta * sin(theta) / (T(2) * (T(1) - cos(theta)))) / theta_squared;
  } else {
    c = T(1) / T(12) + theta_squared / T(720);
  }
  return Eigen::Matrix<T, 3, 3>::Identity() - T(0.5) * W + c * W * W;
}

/// SE(3) exponential of [upsilon; omega].
template <typename T>
Rigid3<T> se3Exp(const Eigen::Matrix<T, 6, 1>& xi) {
  const Eigen::Matrix<T, 3, 1> upsilon = xi.template head<3>();
  const Eigen::Matrix<T, 3, 1> omega = xi.template tail<3>();
  return Rigid3<T>(so3Exp(omega), so3LeftJacobian(omega) * upsilon);
}

/// SE(3) logarithm, [upsilon; omega].
template <typename T>
Eigen::Matrix<T, 6, 1> se3Log(const Rigid3<T>& pose) {
  const Eigen::Matrix<T, 3, 1> omega = so3Log(pose.rotation);
  Eigen::Matrix<T, 6, 1> xi;
  xi.template head<3>() = so3LeftJacobianInverse(omega) * pose.translation;
  xi.template tail<3>() = omega;
  return xi;
}

/// log(a * b^-1): zero when a == b. Both must map the same frames.
template <typename T>
Eigen::Matrix<T, 6, 1> boxMinus(const Rigid3<T>& a, const Rigid3<T>& b) {
  return se3Log(a * b.inverse());
}

/// Angle of the rotation a^-1 * b [rad], in [0, pi].
inline double rotationAngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return so3Log(Eigen::Quaterniond(a.conjugate() * b)).norm();
}

/// Linear interpolation of the translation and slerp of the rotation (the
/// shorter arc), alpha in [0, 1]: alpha = 0 gives a, alpha = 1 gives b.
inline Rigid3d interpolateLinearSlerp(const Rigid3d& a, const Rigid3d& b, double alpha) {
  if (alpha == 0.0) return a;
  if (alpha == 1.0) return b;
  return Rigid3d(a.rotation.slerp(alpha, b.rotation).normalized(),
                 (1.0 - alpha) * a.translation + alpha * b.translation);
}

}  // namespace lookboth
