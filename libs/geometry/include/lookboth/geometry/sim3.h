// Similarity transforms: a rigid transform with a scale, for monocular
// trajectories known up to scale and for alignment of estimates.
//
//     p_in_a = a_from_b * p_in_b = scale * (rotation * p_in_b) + translation
#pragma once

#include "lookboth/geometry/rigid3.h"

namespace lookboth {

template <typename T>
struct Sim3 {
  using Vector3 = Eigen::Matrix<T, 3, 1>;
  using Quaternion = Eigen::Quaternion<T>;

  T scale = T(1);
  Quaternion rotation = Quaternion::Identity();
  Vector3 translation = Vector3::Zero();

  Sim3() = default;
  Sim3(const T& scale_, const Quaternion& rotation_, const Vector3& translation_)
      : scale(scale_), rotation(rotation_), translation(translation_) {}
  explicit Sim3(const Rigid3<T>& rigid)
      : scale(T(1)), rotation(rigid.rotation), translation(rigid.translation) {}

  static Sim3 Identity() { return Sim3(); }

  Sim3 inverse() const {
    const Quaternion inverse_rotation = rotation.conjugate();
    const T inverse_scale = T(1) / scale;
    return Sim3(inverse_scale, inverse_rotation,
                -(inverse_scale * (inverse_rotation * translation)));
  }

  Vector3 operator*(const Vector3& p) const { return scale * (rotation * p) + translation; }

  Sim3 operator*(const Sim3& b_from_c) const {
    return Sim3(scale * b_from_c.scale, rotation * b_from_c.rotation,
                scale * (rotation * b_from_c.translation) + translation);
  }

  /// Maps a pose b_from_c (expressed in b's, possibly unscaled, units) into
  /// a: a_from_c has rotation R*R_bc and origin a_from_b * origin_of_c. The
  /// result is rigid: the scale applies to positions, not to frame c itself.
  Rigid3<T> transformPose(const Rigid3<T>& b_from_c) const {
    return Rigid3<T>(rotation * b_from_c.rotation, (*this) * b_from_c.translation);
  }

  /// 4x4 matrix [sR t; 0 1].
  Eigen::Matrix<T, 4, 4> matrix() const {
    Eigen::Matrix<T, 4, 4> m = Eigen::Matrix<T, 4, 4>::Identity();
    m.template topLeftCorner<3, 3>() = scale * rotation.toRotationMatrix();
    m.template topRightCorner<3, 1>() = translation;
    return m;
  }
};

using Sim3d = Sim3<double>;

}  // namespace lookboth
