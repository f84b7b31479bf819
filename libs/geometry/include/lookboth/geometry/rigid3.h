// Rigid transforms, named by the frames they map.
//
// The rule (doc/conventions.md): a `Rigid3d a_from_b` maps coordinates of a
// point in frame b into frame a:
//
//     p_in_a = a_from_b * p_in_b = a_from_b.rotation * p_in_b + a_from_b.translation
//
// so a product reads right when the inner names cancel:
//
//     world_from_marker = world_from_fisheye * fisheye_from_marker
//
// `a_from_b` is also "the pose of b in a": its translation is the origin of b
// expressed in a, its rotation's columns are b's axes expressed in a. An MRPT
// CPose3D "pose of B in A" is `a_from_b`.
//
// Templated on the scalar so the same code serves double and ceres::Jet.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace lookboth {

template <typename T>
struct Rigid3 {
  using Vector3 = Eigen::Matrix<T, 3, 1>;
  using Quaternion = Eigen::Quaternion<T>;

  /// Unit quaternion. Eigen's storage order is [x y z w] (coeffs()).
  Quaternion rotation = Quaternion::Identity();
  Vector3 translation = Vector3::Zero();

  Rigid3() = default;
  Rigid3(const Quaternion& rotation_, const Vector3& translation_)
      : rotation(rotation_), translation(translation_) {}

  static Rigid3 Identity() { return Rigid3(); }

  /// b_from_a from a_from_b.
  Rigid3 inverse() const {
    const Quaternion inverse_rotation = rotation.conjugate();
    return Rigid3(inverse_rotation, -(inverse_rotation * translation));
  }

  /// p_in_a = a_from_b * p_in_b.
  Vector3 operator*(const Vector3& p) const { return rotation * p + translation; }

  /// a_from_c = a_from_b * b_from_c.
  Rigid3 operator*(const Rigid3& b_from_c) const {
    return Rigid3(rotation * b_from_c.rotation, rotation * b_from_c.translation + translation);
  }

  /// Homogeneous 4x4 matrix [R t; 0 1].
  Eigen::Matrix<T, 4, 4> matrix() const {
    Eigen::Matrix<T, 4, 4> m = Eigen::Matrix<T, 4, 4>::Identity();
    m.template topLeftCorner<3, 3>() = rotation.toRotationMatrix();
    m.template topRightCorner<3, 1>() = translation;
    return m;
  }

  template <typename U>
  Rigid3<U> cast() const {
    return Rigid3<U>(rotation.template cast<U>(), translation.template cast<U>());
  }
};

using Rigid3d = Rigid3<double>;

/// Builds a_from_b from a rotation matrix and a translation; the matrix is
/// re-orthonormalised through the quaternion.
inline Rigid3d rigid3FromMatrix(const Eigen::Matrix4d& a_from_b) {
  Eigen::Quaterniond q(Eigen::Matrix3d(a_from_b.topLeftCorner<3, 3>()));
  q.normalize();
  return Rigid3d(q, a_from_b.topRightCorner<3, 1>());
}

/// ZYX Euler angles (roll about x, pitch about y, yaw about z) of R =
/// Rz(yaw) Ry(pitch) Rx(roll) [rad], each in (-pi, pi], pitch in [-pi/2, pi/2]
/// (URDF's fixed-axis rpy). At pitch +-pi/2 only roll -+ yaw is determined:
/// all of it goes to yaw.
inline Eigen::Vector3d rollPitchYaw(const Eigen::Matrix3d& r) {
  const double pitch = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  if (std::abs(r(2, 0)) >= 1.0 - 1e-12) return {0.0, pitch, std::atan2(-r(0, 1), r(1, 1))};
  return {std::atan2(r(2, 1), r(2, 2)), pitch, std::atan2(r(1, 0), r(0, 0))};
}

}  // namespace lookboth
