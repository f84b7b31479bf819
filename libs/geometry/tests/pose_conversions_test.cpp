#include "lookboth/geometry/pose_conversions.h"

#include <ceres/rotation.h>
#include <gtest/gtest.h>
#include <mrpt/math/TPoint3D.h>

#include "test_utils.h"

namespace lookboth {
namespace {

TEST(PoseConversions, MrptPoseIsAFromB) {
  // yaw 90 deg: B's x axis is A's y axis; B's origin is at (1, 2, 3) in A.
  const mrpt::poses::CPose3D a_from_b(1.0, 2.0, 3.0, M_PI / 2, 0.0, 0.0);
  const Rigid3d pose = fromMrptPose(a_from_b);
  EXPECT_LT((pose * Eigen::Vector3d(1, 0, 0) - Eigen::Vector3d(1, 3, 3)).norm(), 1e-12);
}

TEST(PoseConversions, AgreeWithMrptOnPointsAndComposition) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const Rigid3d a_from_b = testing::randomPose(rng), b_from_c = testing::randomPose(rng);
    const mrpt::poses::CPose3D m_ab = toMrptPose(a_from_b), m_bc = toMrptPose(b_from_c);
    const Eigen::Vector3d p(0.3, -1.2, 2.0);
    mrpt::math::TPoint3D out;
    m_ab.composePoint(mrpt::math::TPoint3D(p.x(), p.y(), p.z()), out);
    EXPECT_LT((Eigen::Vector3d(out.x, out.y, out.z) - a_from_b * p).norm(), 1e-9);
    const Rigid3d composed = fromMrptPose(m_ab + m_bc);  // MRPT '+' composes a_from_b (+) b_from_c
    EXPECT_LT(testing::translationError(composed, a_from_b * b_from_c), 1e-9);
    EXPECT_LT(testing::rotationError(composed, a_from_b * b_from_c), 1e-9);
    const Rigid3d back = fromMrptPose(m_ab);
    EXPECT_LT(testing::translationError(back, a_from_b), 1e-12);
    EXPECT_LT(testing::rotationError(back, a_from_b), 1e-9);
  }
}

TEST(PoseConversions, MrptQuaternionPoseOrderIsXyzQrQxQyQz) {
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized();
  const mrpt::poses::CPose3DQuat m = toMrptPoseQuat(Rigid3d(q, Eigen::Vector3d(1, 2, 3)));
  EXPECT_DOUBLE_EQ(m.quat().r(), q.w());
  EXPECT_DOUBLE_EQ(m.quat().x(), q.x());
  EXPECT_DOUBLE_EQ(m[3], q.w());  // [x y z qr qx qy qz]
  EXPECT_DOUBLE_EQ(m[6], q.z());
  const Rigid3d back = fromMrptPose(m);
  EXPECT_LT(rotationAngleBetween(back.rotation, q), 1e-12);
  // The quaternion pose maps points like the Euler one.
  const mrpt::poses::CPose3D euler(m);
  EXPECT_LT(testing::rotationError(fromMrptPose(euler), back), 1e-9);
}

TEST(PoseConversions, CeresOrderIsWxyz) {
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.7, -0.2, 0.4, 0.1).normalized();
  double wxyz[4];
  toCeresQuaternion(q, wxyz);
  const double p[3] = {1.0, -2.0, 0.5};
  double rotated[3];
  ceres::UnitQuaternionRotatePoint(wxyz, p, rotated);
  EXPECT_LT(
      (Eigen::Vector3d(rotated[0], rotated[1], rotated[2]) - q * Eigen::Vector3d(p[0], p[1], p[2]))
          .norm(),
      1e-12);
  EXPECT_LT(rotationAngleBetween(fromCeresQuaternion(wxyz), q), 1e-12);
}

TEST(PoseConversions, TumVectorAndIsometry) {
  std::mt19937 rng(12);
  const Rigid3d pose = testing::randomPose(rng);
  const Eigen::Matrix<double, 7, 1> v = toTumVector(pose);
  EXPECT_DOUBLE_EQ(v[6], pose.rotation.w());  // qw last
  EXPECT_DOUBLE_EQ(v[3], pose.rotation.x());
  EXPECT_LT(testing::rotationError(fromTumVector(v), pose), 1e-12);
  const Eigen::Isometry3d iso = toIsometry(pose);
  const Eigen::Vector3d p(1, 2, 3);
  EXPECT_LT((iso * p - pose * p).norm(), 1e-12);
  EXPECT_LT((fromIsometry(iso) * p - pose * p).norm(), 1e-12);
}

}  // namespace
}  // namespace lookboth
