#include "lookboth/geometry/pose_conversions.h"

#include <mrpt/math/CMatrixFixed.h>

#include <cmath>

#include "lookboth/geometry/lie.h"

namespace lookboth {

Rigid3d fromMrptPose(const mrpt::poses::CPose3D& a_from_b) {
  Eigen::Matrix3d rotation = a_from_b.getRotationMatrix().asEigen();
  Eigen::Quaterniond q(rotation);
  q.normalize();
  return Rigid3d(q, Eigen::Vector3d(a_from_b.x(), a_from_b.y(), a_from_b.z()));
}

mrpt::poses::CPose3D toMrptPose(const Rigid3d& a_from_b) {
  const Eigen::Matrix3d rotation = a_from_b.rotation.normalized().toRotationMatrix();
  mrpt::math::CMatrixDouble33 r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r(i, j) = rotation(i, j);
  }
  mrpt::math::CVectorFixedDouble<3> t;
  t[0] = a_from_b.translation.x();
  t[1] = a_from_b.translation.y();
  t[2] = a_from_b.translation.z();
  return mrpt::poses::CPose3D(r, t);
}

Rigid3d fromMrptPose(const mrpt::poses::CPose3DQuat& a_from_b) {
  const auto& q = a_from_b.quat();
  Eigen::Quaterniond rotation(q.r(), q.x(), q.y(), q.z());
  rotation.normalize();
  return Rigid3d(rotation, Eigen::Vector3d(a_from_b.x(), a_from_b.y(), a_from_b.z()));
}

mrpt::poses::CPose3DQuat toMrptPoseQuat(const Rigid3d& a_from_b) {
  const Eigen::Quaterniond q = a_from_b.rotation.normalized();
  return mrpt::poses::CPose3DQuat(a_from_b.translation.x(), a_from_b.translation.y(),
                                  a_from_b.translation.z(),
                                  mrpt::math::CQuaternionDouble(q.w(), q.x(), q.y(), q.z()));
}

Rigid3d fromIsometry(const Eigen::Isometry3d& a_from_b) {
  Eigen::Quaterniond q(a_from_b.rotation());
  q.normalize();
  return Rigid3d(q, a_from_b.translation());
}

Eigen::Isometry3d toIsometry(const Rigid3d& a_from_b) {
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.linear() = a_from_b.rotation.normalized().toRotationMatrix();
  iso.translation() = a_from_b.translation;
  return iso;
}

void toCeresQuaternion(const Eigen::Quaterniond& q, double* wxyz) {
  wxyz[0] = q.w();
  wxyz[1] = q.x();
  wxyz[2] = q.y();
  wxyz[3] = q.z();
}

Eigen::Quaterniond fromCeresQuaternion(const double* wxyz) {
  return Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
}

Eigen::Matrix<double, 7, 1> toTumVector(const Rigid3d& a_from_b) {
  Eigen::Matrix<double, 7, 1> v;
  const Eigen::Quaterniond& q = a_from_b.rotation;
  v << a_from_b.translation, q.x(), q.y(), q.z(), q.w();
  return v;
}

Rigid3d fromTumVector(const Eigen::Matrix<double, 7, 1>& tum) {
  Eigen::Quaterniond q(tum[6], tum[3], tum[4], tum[5]);
  q.normalize();
  return Rigid3d(q, tum.head<3>());
}

namespace {

/// d(yaw, pitch, roll)/d(dtheta) of R Exp(dtheta) at `pose`, by central differences.
Eigen::Matrix3d yawPitchRollJacobian(const Rigid3d& pose) {
  Eigen::Matrix3d j;
  const double h = 1e-7;
  for (int k = 0; k < 3; ++k) {
    Eigen::Vector3d d = Eigen::Vector3d::Zero();
    d[k] = h;
    double ypr_plus[3], ypr_minus[3];
    const Rigid3d plus(pose.rotation * so3Exp(d), pose.translation);
    const Rigid3d minus(pose.rotation * so3Exp(Eigen::Vector3d(-d)), pose.translation);
    toMrptPose(plus).getYawPitchRoll(ypr_plus[0], ypr_plus[1], ypr_plus[2]);
    toMrptPose(minus).getYawPitchRoll(ypr_minus[0], ypr_minus[1], ypr_minus[2]);
    for (int i = 0; i < 3; ++i) {
      double difference = ypr_plus[i] - ypr_minus[i];
      difference = std::remainder(difference, 2 * M_PI);  // across +-pi
      j(i, k) = difference / (2 * h);
    }
  }
  return j;
}

}  // namespace

mrpt::poses::CPose3DPDFGaussian toMrptPosePdf(const Rigid3d& pose,
                                              const Eigen::Matrix<double, 6, 6>& covariance) {
  Eigen::Matrix<double, 6, 6> j = Eigen::Matrix<double, 6, 6>::Zero();
  j.topLeftCorner<3, 3>().setIdentity();
  j.bottomRightCorner<3, 3>() = yawPitchRollJacobian(pose);
  const Eigen::Matrix<double, 6, 6> mrpt_covariance = j * covariance * j.transpose();
  mrpt::math::CMatrixDouble66 cov;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) cov(r, c) = mrpt_covariance(r, c);
  }
  return mrpt::poses::CPose3DPDFGaussian(toMrptPose(pose), cov);
}

}  // namespace lookboth
