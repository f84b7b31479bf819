// The joint stage's cached blob residual (FramePoseCache + CachedBlobCost)
// against the reference autodiff BlobCost: same residuals, same Jacobians.
#include <gtest/gtest.h>

#include <random>

#include "../src/joint_costs.h"
#include "lookboth/cameras/camera_io.h"

namespace lookboth {
namespace {

using joint_detail::BlobCost;
using joint_detail::Bracket;
using joint_detail::CachedBlobCost;
using joint_detail::FramePoseCache;

Rigid3d randomPose(std::mt19937& rng, double translation, double angle) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d t(n(rng), n(rng), n(rng));
  const Eigen::Vector3d w(n(rng), n(rng), n(rng));
  return Rigid3d(so3Exp(Eigen::Vector3d(w * angle)), t * translation);
}

TEST(JointCosts, CachedBlobCostMatchesTheAutodiffReference) {
  const Camera fisheye =
      loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_640x360_calib_results.txt");
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int compared = 0;
  for (int trial = 0; trial < 50; ++trial) {
    // A frame between two nodes whose corrections differ from the reference.
    Bracket b;
    b.duration_s = 0.1;
    b.tau_ref_s = 0.1 * u(rng);
    const Rigid3d ref_k = randomPose(rng, 2.0, 0.3);
    const Rigid3d ref_k1 = ref_k * randomPose(rng, 0.05, 0.02);
    b.ref_inverse_k = ref_k.inverse();
    b.ref_inverse_k1 = ref_k1.inverse();
    b.reference = ref_k * randomPose(rng, 0.02, 0.01);
    double nk[7], nk1[7], camera[7];
    calib_detail::poseToParams(ref_k * randomPose(rng, 0.01, 0.005), nk);
    calib_detail::poseToParams(ref_k1 * randomPose(rng, 0.01, 0.005), nk1);
    // A ceiling camera 3 m above the frame, within the fisheye's view.
    const Rigid3d world_from_fisheye = joint_detail::poseAt<double>(b, nk, nk1, b.tau_ref_s);
    const Eigen::Vector3d in_fisheye(4 * (u(rng) - 0.5), 4 * (u(rng) - 0.5), 3.0);
    const Rigid3d world_from_camera(so3Exp(Eigen::Vector3d(3 * u(rng), 0.1, -0.2)),
                                    world_from_fisheye * in_fisheye);
    calib_detail::poseToParams(world_from_camera, camera);
    const Eigen::Vector3d offset(0.01, -0.02, 0.03);
    const Eigen::Vector2d observed(320 + 20 * u(rng), 180 + 20 * u(rng));

    auto* reference = new BlobCost;
    reference->bracket = b;
    reference->fisheye = &fisheye;
    reference->offset_in_camera = offset;
    reference->observed = observed;
    reference->sigma_px = 0.7;
    const ceres::AutoDiffCostFunction<BlobCost, 2, 7, 7, 7> expected_cost(reference);

    FramePoseCache cache;
    const std::size_t slot = cache.add(b, nk, nk1);
    cache.PrepareForEvaluation(true, true);
    const CachedBlobCost cost(&cache, slot, &fisheye, offset, observed, 0.7);

    const double* blocks[3] = {nk, nk1, camera};
    double r0[2], r1[2], j0[3][14], j1[3][14];
    double* jac0[3] = {j0[0], j0[1], j0[2]};
    double* jac1[3] = {j1[0], j1[1], j1[2]};
    ASSERT_TRUE(expected_cost.Evaluate(blocks, r0, jac0));
    ASSERT_TRUE(cost.Evaluate(blocks, r1, jac1));
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(r1[i], r0[i], 1e-9 * (1 + std::abs(r0[i])));
    for (int blk = 0; blk < 3; ++blk) {
      for (int i = 0; i < 14; ++i) {
        EXPECT_NEAR(j1[blk][i], j0[blk][i], 1e-7 * (1 + std::abs(j0[blk][i])))
            << "trial " << trial << " block " << blk << " entry " << i;
      }
    }
    // Residuals only, then a point with values but no Jacobians prepared.
    double r2[2];
    ASSERT_TRUE(cost.Evaluate(blocks, r2, nullptr));
    EXPECT_NEAR(r2[0], r0[0], 1e-9 * (1 + std::abs(r0[0])));
    ++compared;
  }
  EXPECT_EQ(compared, 50);
}

TEST(JointCosts, CacheRecomputesAtANewPointAndWhenJacobiansAreAskedLater) {
  Bracket b;
  b.duration_s = 0.1;
  b.tau_ref_s = 0.04;
  double nk[7], nk1[7];
  calib_detail::poseToParams(Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0)), nk);
  calib_detail::poseToParams(Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(2, 0, 0)),
                             nk1);
  FramePoseCache cache;
  const std::size_t slot = cache.add(b, nk, nk1);
  cache.PrepareForEvaluation(false, true);
  EXPECT_NEAR(cache.pose(slot)[0], 1.4, 1e-12);  // 1 + 0.4 * (2 - 1)
  nk1[0] = 3;
  cache.PrepareForEvaluation(false, false);  // same point: nothing recomputed
  EXPECT_NEAR(cache.pose(slot)[0], 1.4, 1e-12);
  cache.PrepareForEvaluation(true, false);  // Jacobians asked for: computed now
  EXPECT_NEAR(cache.pose(slot)[0], 1.8, 1e-12);
  EXPECT_NEAR(cache.jacobian(slot)(0, 0), 0.6, 1e-12);  // d x / d node_k.x
  EXPECT_NEAR(cache.jacobian(slot)(0, 7), 0.4, 1e-12);  // d x / d node_k+1.x
  nk[0] = 0;
  cache.PrepareForEvaluation(false, true);
  EXPECT_NEAR(cache.pose(slot)[0], 1.2, 1e-12);
}

}  // namespace
}  // namespace lookboth
