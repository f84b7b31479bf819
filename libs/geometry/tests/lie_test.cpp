#include "lookboth/geometry/lie.h"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include "lookboth/geometry/random.h"
#include "lookboth/geometry/sim3.h"
#include "test_utils.h"

namespace lookboth {
namespace {

using testing::randomPose;
using testing::randomRotation;

TEST(Rigid3, ComposesInverseAndMapsPoints) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d a_from_b = randomPose(rng), b_from_c = randomPose(rng);
    const Eigen::Vector3d p_in_c(1.0, -2.0, 3.5);
    const Rigid3d a_from_c = a_from_b * b_from_c;
    EXPECT_LT((a_from_c * p_in_c - a_from_b * (b_from_c * p_in_c)).norm(), 1e-12);
    EXPECT_LT((a_from_b.inverse() * (a_from_b * p_in_c) - p_in_c).norm(), 1e-12);
    EXPECT_LT((a_from_c.matrix() - a_from_b.matrix() * b_from_c.matrix()).norm(), 1e-12);
    EXPECT_LT((rigid3FromMatrix(a_from_c.matrix()) * p_in_c - a_from_c * p_in_c).norm(), 1e-12);
  }
}

TEST(Sim3, ComposesInvertsAndTransformsPoses) {
  std::mt19937 rng(2);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d r1 = randomPose(rng), r2 = randomPose(rng);
    const Sim3d a_from_b(2.5, r1.rotation, r1.translation),
        b_from_c(0.3, r2.rotation, r2.translation);
    const Eigen::Vector3d p(0.5, 1.0, -4.0);
    EXPECT_LT(((a_from_b * b_from_c) * p - a_from_b * (b_from_c * p)).norm(), 1e-12);
    EXPECT_LT((a_from_b.inverse() * (a_from_b * p) - p).norm(), 1e-12);
    EXPECT_LT((a_from_b.matrix() * p.homogeneous() - (a_from_b * p).homogeneous()).norm(), 1e-12);
    // transformPose: origin mapped as a point, axes rotated, no scaling of the frame.
    const Rigid3d b_from_x = randomPose(rng);
    const Rigid3d a_from_x = a_from_b.transformPose(b_from_x);
    EXPECT_LT((a_from_x.translation - a_from_b * b_from_x.translation).norm(), 1e-12);
    EXPECT_LT(rotationAngleBetween(a_from_x.rotation, a_from_b.rotation * b_from_x.rotation),
              1e-12);
  }
}

TEST(Lie, So3ExpLogRoundTripIncludingSmallAndNearPiAngles) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double angle : {0.0, 1e-12, 1e-7, 1e-3, 0.5, 2.0, M_PI - 1e-6}) {
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Vector3d axis = drawVector<3>([&] { return u(rng); }).normalized();
      const Eigen::Vector3d omega = angle * axis;
      const Eigen::Quaterniond q = so3Exp(omega);
      EXPECT_NEAR(q.norm(), 1.0, 1e-15);
      const Eigen::Quaterniond reference(Eigen::AngleAxisd(angle, axis));
      EXPECT_LT(rotationAngleBetween(q, reference), 1e-12) << angle;
      EXPECT_LT((so3Log(q) - omega).norm(), 1e-9 * std::max(1.0, angle)) << angle;
    }
  }
}

TEST(Lie, Se3ExpLogRoundTripAndTrueLog) {
  std::mt19937 rng(4);
  for (int trial = 0; trial < 200; ++trial) {
    const Rigid3d pose = randomPose(rng);
    const Eigen::Matrix<double, 6, 1> xi = se3Log(pose);
    const Rigid3d back = se3Exp(xi);
    EXPECT_LT(testing::translationError(back, pose), 1e-9);
    EXPECT_LT(testing::rotationError(back, pose), 1e-9);
  }
  // A screw motion: rotation about z by a quarter turn with translation along
  // x; the true log differs from the translation itself (unlike MRPT's pseudo-log).
  Eigen::Matrix<double, 6, 1> xi;
  xi << 1.0, 0.0, 0.0, 0.0, 0.0, M_PI / 2;
  const Rigid3d screw = se3Exp(xi);
  EXPECT_GT((screw.translation - xi.head<3>()).norm(), 0.1);
  EXPECT_LT((se3Log(screw) - xi).norm(), 1e-12);
}

TEST(Lie, BoxMinusIsZeroForEqualPosesAndSmallForNearbyOnes) {
  std::mt19937 rng(5);
  const Rigid3d a = randomPose(rng);
  EXPECT_LT(boxMinus(a, a).norm(), 1e-12);
  Eigen::Matrix<double, 6, 1> delta;
  delta << 1e-4, -2e-4, 3e-4, 1e-5, 2e-5, -3e-5;
  const Rigid3d b = se3Exp(delta) * a;  // left perturbation
  EXPECT_LT((boxMinus(b, a) - delta).norm(), 1e-12);
}

TEST(Lie, InterpolationSlerpsMidway) {
  const Rigid3d a(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0));
  const Rigid3d b(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())),
                  Eigen::Vector3d(2, 4, 6));
  const Rigid3d mid = interpolateLinearSlerp(a, b, 0.5);
  EXPECT_LT((mid.translation - Eigen::Vector3d(1, 2, 3)).norm(), 1e-15);
  const Eigen::Quaterniond expected(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()));
  EXPECT_LT(rotationAngleBetween(mid.rotation, expected), 1e-12);
  // The shorter arc is taken even when the stored quaternions have opposite signs.
  Rigid3d b_flipped = b;
  b_flipped.rotation.coeffs() = -b.rotation.coeffs();
  EXPECT_LT(rotationAngleBetween(interpolateLinearSlerp(a, b_flipped, 0.5).rotation, expected),
            1e-12);
}

// The maps must instantiate for ceres::Jet and give the derivatives a
// numeric difference gives.
TEST(Lie, ExpDerivativesWithJetsMatchNumericDifferences) {
  using Jet = ceres::Jet<double, 3>;
  for (const Eigen::Vector3d& omega :
       {Eigen::Vector3d(0.3, -0.2, 0.9), Eigen::Vector3d(1e-9, 2e-9, -1e-9)}) {
    Eigen::Matrix<Jet, 3, 1> omega_jet;
    for (int i = 0; i < 3; ++i) omega_jet[i] = Jet(omega[i], i);
    const Eigen::Vector3d p(1.0, 2.0, 3.0);
    const Eigen::Matrix<Jet, 3, 1> rotated = so3Exp(omega_jet) * p.cast<Jet>();
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      Eigen::Vector3d plus = omega, minus = omega;
      plus[i] += h;
      minus[i] -= h;
      const Eigen::Vector3d numeric = (so3Exp(plus) * p - so3Exp(minus) * p) / (2 * h);
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(rotated[r].v[i], numeric[r], 1e-7);
    }
    // se3Log of a Jet pose compiles and agrees in value.
    Rigid3<Jet> pose(so3Exp(omega_jet), Eigen::Matrix<Jet, 3, 1>(Jet(1.0), Jet(2.0), Jet(3.0)));
    const Eigen::Matrix<Jet, 6, 1> xi = se3Log(pose);
    const Eigen::Matrix<double, 6, 1> xi_double =
        se3Log(Rigid3d(so3Exp(omega), Eigen::Vector3d(1, 2, 3)));
    for (int r = 0; r < 6; ++r) EXPECT_NEAR(xi[r].a, xi_double[r], 1e-12);
  }
}

}  // namespace
}  // namespace lookboth
