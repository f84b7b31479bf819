#include "lookboth/geometry/umeyama.h"
#include "lookboth/geometry/random.h"

#include <gtest/gtest.h>

#include "test_utils.h"

namespace lookboth {
namespace {

std::vector<Eigen::Vector3d> randomPoints(std::mt19937& rng, int n) {
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i)
    points.push_back(
        drawVector<3>([&] { return u(rng); }).cwiseProduct(Eigen::Vector3d(1, 1, 0.1)));
  return points;
}

TEST(Umeyama, RecoversSim3FromNoiseFreePoints) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> scale(0.05, 20.0);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d r = testing::randomPose(rng);
    const Sim3d truth(scale(rng), r.rotation, r.translation);
    const auto src = randomPoints(rng, 3 + trial % 20);
    std::vector<Eigen::Vector3d> dst;
    for (const auto& p : src) dst.push_back(truth * p);
    const auto result = alignSim3(src, dst);
    ASSERT_TRUE(result);
    EXPECT_NEAR(result->dst_from_src.scale, truth.scale, 1e-9 * truth.scale);
    EXPECT_LT(rotationAngleBetween(result->dst_from_src.rotation, truth.rotation), 1e-9);
    EXPECT_LT((result->dst_from_src.translation - truth.translation).norm(), 1e-9);
    EXPECT_LT(result->rms_error, 1e-9);
  }
}

TEST(Umeyama, RigidAlignmentKeepsScaleOne) {
  std::mt19937 rng(32);
  const Rigid3d truth = testing::randomPose(rng);
  const auto src = randomPoints(rng, 10);
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : src) dst.push_back(truth * p);
  const auto result = alignRigid3(src, dst);
  ASSERT_TRUE(result);
  EXPECT_EQ(result->dst_from_src.scale, 1.0);
  EXPECT_LT(rotationAngleBetween(result->dst_from_src.rotation, truth.rotation), 1e-9);
  EXPECT_LT((result->dst_from_src.translation - truth.translation).norm(), 1e-9);
}

TEST(Umeyama, NoisyPointsWithinABoundFromTheNoise) {
  std::mt19937 rng(33);
  const double sigma = 0.01;  // 1 cm
  std::normal_distribution<double> noise(0.0, sigma);
  const Rigid3d r = testing::randomPose(rng);
  const Sim3d truth(1.7, r.rotation, r.translation);
  const auto src = randomPoints(rng, 400);
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : src) dst.push_back(truth * p + drawVector<3>([&] { return noise(rng); }));
  const auto result = alignSim3(src, dst);
  ASSERT_TRUE(result);
  // The residual RMS estimates the 3-D noise: sigma * sqrt(3).
  EXPECT_NEAR(result->rms_error, sigma * std::sqrt(3.0), 0.15 * sigma * std::sqrt(3.0));
  // Points spread over ~20 m with 400 samples: rotation to well under a milliradian.
  EXPECT_LT(rotationAngleBetween(result->dst_from_src.rotation, truth.rotation), 5e-4);
  EXPECT_NEAR(result->dst_from_src.scale, 1.7, 1e-3);
}

TEST(Umeyama, WeightsSelectTheInliers) {
  std::mt19937 rng(34);
  const Rigid3d truth = testing::randomPose(rng);
  auto src = randomPoints(rng, 20);
  std::vector<Eigen::Vector3d> dst;
  std::vector<double> weights;
  for (size_t i = 0; i < src.size(); ++i) {
    const bool outlier = i % 5 == 0;
    dst.push_back(truth * src[i] + (outlier ? Eigen::Vector3d(5, -3, 2) : Eigen::Vector3d::Zero()));
    weights.push_back(outlier ? 0.0 : 1.0);
  }
  const auto result = alignRigid3(src, dst, weights);
  ASSERT_TRUE(result);
  EXPECT_LT((result->dst_from_src.translation - truth.translation).norm(), 1e-9);
}

TEST(Umeyama, RefusesDegenerateInputWithAReason) {
  std::string why;
  EXPECT_FALSE(alignSim3({{0, 0, 0}, {1, 1, 1}}, {{0, 0, 0}, {1, 1, 1}}, {}, &why));
  EXPECT_NE(why.find("at least 3"), std::string::npos) << why;
  const std::vector<Eigen::Vector3d> line = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {5, 5, 5}};
  EXPECT_FALSE(alignSim3(line, line, {}, &why));
  EXPECT_NE(why.find("collinear"), std::string::npos) << why;
  EXPECT_FALSE(alignSim3(line, {{0, 0, 0}}, {}, &why));
  EXPECT_NE(why.find("different numbers"), std::string::npos) << why;
}

TEST(Umeyama, AlignsPosesByTheirPositions) {
  std::mt19937 rng(35);
  const Rigid3d r = testing::randomPose(rng);
  const Sim3d b_from_a(0.4, r.rotation, r.translation);
  std::vector<Rigid3d> a_from_x, b_from_x;
  for (int i = 0; i < 12; ++i) {
    a_from_x.push_back(testing::randomPose(rng));
    b_from_x.push_back(b_from_a.transformPose(a_from_x.back()));
  }
  const auto result = alignPoses(a_from_x, b_from_x, /*with_scale=*/true);
  ASSERT_TRUE(result);
  EXPECT_NEAR(result->dst_from_src.scale, 0.4, 1e-9);
  EXPECT_LT(rotationAngleBetween(result->dst_from_src.rotation, b_from_a.rotation), 1e-9);
}

}  // namespace
}  // namespace lookboth
