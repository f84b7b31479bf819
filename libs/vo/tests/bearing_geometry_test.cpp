// Two-view and absolute geometry on bearings, COLMAP style: ground truth ->
// (noise) -> solve -> bound. Noise-free geometry is recovered to 1e-6.
#include "lookboth/vo/bearing_geometry.h"

#include <gtest/gtest.h>

#include <iostream>
#include <random>

#include "lookboth/core/test_seed.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"

namespace lookboth::vo {
namespace {

/// Points on and around a ceiling 3.5 m above the first camera (z up = the
/// fisheye's optical axis), spread over +-80 deg of incidence.
std::vector<Eigen::Vector3d> ceilingPoints(std::mt19937& rng, int n, double relief) {
  std::uniform_real_distribution<double> angle(0, 2 * M_PI), incidence(0, 80 * M_PI / 180),
      dz(-relief, relief);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    const double a = angle(rng), inc = incidence(rng);
    const double h = 3.5 + dz(rng);
    const double r = h * std::tan(inc);
    points.emplace_back(r * std::cos(a), r * std::sin(a), h);
  }
  return points;
}

Rigid3d randomMotion(std::mt19937& rng, double translation, double rotation) {
  std::normal_distribution<double> n(0, 1);
  const Eigen::Vector3d w = drawVector<3>([&] { return n(rng); });
  const Eigen::Vector3d t =
      drawVector<3>([&] { return n(rng); }).cwiseProduct(Eigen::Vector3d(1, 1, 0.2));
  return Rigid3d(so3Exp<double>(rotation * w.normalized()), translation * t.normalized());
}

Eigen::Vector3d bearingIn(const Rigid3d& world_from_camera, const Eigen::Vector3d& p) {
  return (world_from_camera.inverse() * p).normalized();
}

class RelativePose : public ::testing::TestWithParam<double> {};

TEST_P(RelativePose, NoiseFreeRecoveredTo1e6) {
  const double relief = GetParam();  // 0: a perfectly planar ceiling.
  for (int trial = 0; trial < 10; ++trial) {
    std::mt19937 rng(100 + trial);
    const auto points = ceilingPoints(rng, 200, relief);
    const Rigid3d world_from_cam2 = randomMotion(rng, 0.3, 0.2);
    Bearings b1, b2;
    for (const auto& p : points) {
      b1.push_back(bearingIn(Rigid3d::Identity(), p));
      b2.push_back(bearingIn(world_from_cam2, p));
    }
    RansacOptions options;
    options.threshold_rad = 1e-4;
    options.seed = 7 + trial;
    const auto result = estimateRelativePose(b1, b2, options);
    ASSERT_TRUE(result) << "trial " << trial;
    EXPECT_EQ(result->num_inliers, 200) << "trial " << trial;
    EXPECT_LT(rotationAngleBetween(result->cam1_from_cam2.rotation, world_from_cam2.rotation), 1e-6)
        << "trial " << trial;
    const Eigen::Vector3d t_true = world_from_cam2.translation.normalized();
    EXPECT_LT((result->cam1_from_cam2.translation - t_true).norm(), 1e-6) << "trial " << trial;
  }
}

INSTANTIATE_TEST_SUITE_P(Scenes, RelativePose, ::testing::Values(0.0, 0.5));

TEST(RelativePoseTest, NoisyWithOutliersWithinBound) {
  std::mt19937 rng(testSeed(3));
  const auto points = ceilingPoints(rng, 300, 0.5);
  const Rigid3d world_from_cam2 = randomMotion(rng, 0.3, 0.1);
  std::normal_distribution<double> noise(0, 0.002);  // ~0.4 px at 200 px/rad
  Bearings b1, b2;
  for (size_t i = 0; i < points.size(); ++i) {
    b1.push_back((bearingIn(Rigid3d::Identity(), points[i]) + drawVector<3>([&] {
                    return noise(rng);
                  })).normalized());
    Eigen::Vector3d b = bearingIn(world_from_cam2, points[i]);
    if (i % 5 == 0) b = (b + Eigen::Vector3d(0.3, -0.2, 0.1)).normalized();  // 20 % outliers
    b2.push_back((b + drawVector<3>([&] { return noise(rng); })).normalized());
  }
  RansacOptions options;
  options.threshold_rad = 0.01;
  options.seed = testSeed(options.seed);
  const auto result = estimateRelativePose(b1, b2, options);
  ASSERT_TRUE(result);
  const double rotation_error =
      rotationAngleBetween(result->cam1_from_cam2.rotation, world_from_cam2.rotation);
  const double direction_error =
      std::acos(result->cam1_from_cam2.translation.dot(world_from_cam2.translation.normalized()));
  std::cout << "noisy relative pose: " << result->num_inliers << " inliers, rotation error "
            << rotation_error << " rad, translation direction error " << direction_error
            << " rad\n";
  EXPECT_GE(result->num_inliers, 230);
  EXPECT_LT(rotation_error, 0.005);
  EXPECT_LT(direction_error, 0.05);
}

TEST(AbsolutePoseTest, NoiseFreeRecoveredTo1e6) {
  for (int trial = 0; trial < 10; ++trial) {
    std::mt19937 rng(200 + trial);
    const auto points = ceilingPoints(rng, 100, 0.5);
    const Rigid3d world_from_camera = randomMotion(rng, 1.0, 0.5);
    Bearings b;
    for (const auto& p : points) b.push_back(bearingIn(world_from_camera, p));
    RansacOptions options;
    options.threshold_rad = 1e-4;
    options.seed = trial;
    const auto result = estimateAbsolutePose(b, points, options);
    ASSERT_TRUE(result);
    EXPECT_EQ(result->num_inliers, 100);
    EXPECT_LT(rotationAngleBetween(result->world_from_camera.rotation, world_from_camera.rotation),
              1e-6);
    EXPECT_LT((result->world_from_camera.translation - world_from_camera.translation).norm(), 1e-6);
  }
}

TEST(TriangulationTest, MidpointExactAndRejectsParallelRays) {
  const Eigen::Vector3d p(0.4, -0.3, 3.2);
  const Rigid3d a = Rigid3d::Identity();
  const Rigid3d b(so3Exp<double>(Eigen::Vector3d(0.05, -0.02, 0.3)),
                  Eigen::Vector3d(0.5, 0.1, 0.02));
  const auto q = triangulateMidpoint(a, bearingIn(a, p), b, bearingIn(b, p), 0.01);
  ASSERT_TRUE(q);
  EXPECT_LT((*q - p).norm(), 1e-9);
  EXPECT_FALSE(triangulateMidpoint(a, bearingIn(a, p), a, bearingIn(a, p), 0.01));
}

TEST(TangentBasisTest, OrthonormalAndOrthogonalToBearing) {
  for (const Eigen::Vector3d& f : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0),
                                   Eigen::Vector3d(0.3, -0.9, -0.2).normalized()}) {
    const Eigen::Matrix<double, 2, 3> basis = tangentBasis(f);
    EXPECT_NEAR((basis * basis.transpose() - Eigen::Matrix2d::Identity()).norm(), 0, 1e-12);
    EXPECT_NEAR((basis * f).norm(), 0, 1e-12);
  }
}

}  // namespace
}  // namespace lookboth::vo
