// A pose as a Ceres parameter block: [tx ty tz qx qy qz qw] (Eigen's
// quaternion storage order) with the manifold x [+] delta = (t + dt,
// R Exp(dtheta)), delta = [dt; dtheta]. That is the perturbation of the
// registration's covariances (doc/conventions.md), so Ceres' tangent-space
// covariance of a block is directly the one reported.
#pragma once
#include <ceres/autodiff_manifold.h>
#include <ceres/manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/rigid3.h"

namespace lookboth {

/// The manifold's operations, templated (AutoDiffManifold's form: the tests'
/// reference for PoseManifold's Jacobians).
struct RightPerturbedPose {
  template <typename T>
  bool Plus(const T* x, const T* delta, T* x_plus_delta) const {
    for (int i = 0; i < 3; ++i) x_plus_delta[i] = x[i] + delta[i];
    const Eigen::Map<const Eigen::Quaternion<T>> q(x + 3);
    const Eigen::Matrix<T, 3, 1> omega(delta[3], delta[4], delta[5]);
    Eigen::Map<Eigen::Quaternion<T>> out(x_plus_delta + 3);
    out = q * so3Exp(omega);
    return true;
  }
  template <typename T>
  bool Minus(const T* y, const T* x, T* y_minus_x) const {
    for (int i = 0; i < 3; ++i) y_minus_x[i] = y[i] - x[i];
    const Eigen::Map<const Eigen::Quaternion<T>> qy(y + 3);
    const Eigen::Map<const Eigen::Quaternion<T>> qx(x + 3);
    const Eigen::Matrix<T, 3, 1> omega = so3Log(Eigen::Quaternion<T>(qx.conjugate() * qy));
    for (int i = 0; i < 3; ++i) y_minus_x[3 + i] = omega[i];
    return true;
  }
};

/// RightPerturbedPose with its Jacobians at delta = 0 written out (Ceres asks
/// for PlusJacobian at every Jacobian evaluation, for every block):
/// d(q Exp(dtheta))/d dtheta = 1/2 q (x) [dtheta; 0], and
/// d Log(q_x^-1 q_y)/d q_y at q_y = q_x = 2 (q_x^-1 (x) dq_y).vec.
/// (Tests compare them with AutoDiffManifold's.)
class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override {
    return RightPerturbedPose().Plus(x, delta, x_plus_delta);
  }
  bool PlusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> j(jacobian);
    j.setZero();
    j.topLeftCorner<3, 3>().setIdentity();
    const Eigen::Map<const Eigen::Quaterniond> q(x + 3);
    for (int i = 0; i < 3; ++i) {
      Eigen::Quaterniond e(0, 0, 0, 0);
      e.vec()[i] = 0.5;
      j.block<4, 1>(3, 3 + i) = (q * e).coeffs();
    }
    return true;
  }
  bool Minus(const double* y, const double* x, double* y_minus_x) const override {
    return RightPerturbedPose().Minus(y, x, y_minus_x);
  }
  bool MinusJacobian(const double* x, double* jacobian) const override {
    Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> j(jacobian);
    j.setZero();
    j.topLeftCorner<3, 3>().setIdentity();
    const Eigen::Map<const Eigen::Quaterniond> q(x + 3);
    for (int i = 0; i < 4; ++i) {
      Eigen::Quaterniond e(0, 0, 0, 0);
      e.coeffs()[i] = 2.0;
      j.block<3, 1>(3, 3 + i) = (q.conjugate() * e).vec();
    }
    return true;
  }
};

inline ceres::Manifold* newPoseManifold() { return new PoseManifold; }

inline void poseToParams(const Rigid3d& pose, double* params) {
  const Eigen::Quaterniond q = pose.rotation.normalized();
  params[0] = pose.translation.x();
  params[1] = pose.translation.y();
  params[2] = pose.translation.z();
  params[3] = q.x();
  params[4] = q.y();
  params[5] = q.z();
  params[6] = q.w();
}

inline Rigid3d paramsToPose(const double* params) {
  Eigen::Quaterniond q(params[6], params[3], params[4], params[5]);
  q.normalize();
  return Rigid3d(q, Eigen::Vector3d(params[0], params[1], params[2]));
}

template <typename T>
Rigid3<T> poseFromParams(const T* params) {
  const Eigen::Map<const Eigen::Quaternion<T>> q(params + 3);
  return Rigid3<T>(Eigen::Quaternion<T>(q),
                   Eigen::Matrix<T, 3, 1>(params[0], params[1], params[2]));
}

/// The 6-vector error of an estimate against a measurement in the
/// covariance convention: [t_est - t_meas; log(R_meas^T R_est)].
template <typename T>
Eigen::Matrix<T, 6, 1> poseError(const Rigid3<T>& estimate, const Rigid3d& measured) {
  Eigen::Matrix<T, 6, 1> e;
  e.template head<3>() = estimate.translation - measured.translation.cast<T>();
  e.template tail<3>() =
      so3Log(Eigen::Quaternion<T>(measured.rotation.cast<T>().conjugate() * estimate.rotation));
  return e;
}

inline Eigen::Matrix<double, 6, 1> poseErrorD(const Rigid3d& estimate, const Rigid3d& measured) {
  return poseError<double>(estimate, measured);
}

}  // namespace lookboth
