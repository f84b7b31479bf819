// Private: pose helpers shared by the stages (their pose parameter blocks are
// lookboth/solver/pose_block.h's).
#pragma once
#include <ceres/autodiff_manifold.h>
#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/rigid3.h"
#include "lookboth/registration/registration.h"
#include "lookboth/solver/pose_block.h"

namespace lookboth::calib_detail {

/// A square root S of an information matrix (S^T S = information).
inline Matrix6d sqrtInformation(const Matrix6d& information) {
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (information + information.transpose()));
  const Eigen::Matrix<double, 6, 1> values = eig.eigenvalues().cwiseMax(0.0);
  return values.cwiseSqrt().asDiagonal() * eig.eigenvectors().transpose();
}

/// Rotation angle [rad] of a quaternion.
inline double angleOf(const Eigen::Quaterniond& q) { return so3Log(q.normalized()).norm(); }

/// Chordal mean of rotations (the quaternion of the largest eigenvector of sum q q^T).
inline Eigen::Quaterniond meanRotation(const std::vector<Eigen::Quaterniond>& rotations) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  for (const Eigen::Quaterniond& q : rotations) m += q.coeffs() * q.coeffs().transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(m);
  Eigen::Vector4d c = eig.eigenvectors().col(3);
  return Eigen::Quaterniond(c[3], c[0], c[1], c[2]).normalized();
}

}  // namespace lookboth::calib_detail
