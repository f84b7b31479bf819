// The joint stage's cached blob residual (FramePoseCache + CachedBlobCost)
// against the reference autodiff BlobCost: same residuals, same Jacobians.
#include <gtest/gtest.h>

#include <iostream>
#include <random>

#include "../src/joint_adjustment.h"
#include "../src/joint_costs.h"
#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/test_seed.h"
#include "lookboth/geometry/random.h"

namespace lookboth {
namespace {

using joint_detail::BlobCost;
using joint_detail::Bracket;
using joint_detail::CachedBlobCost;
using joint_detail::FramePoseCache;

// A pose block's Jacobian (rows x 7, stored numbers) times the manifold's
// PlusJacobian: the tangent Jacobian (rows x 6) that Ceres uses.
Eigen::MatrixXd tangentJacobian(const double* block, const double* jacobian, int rows) {
  const std::unique_ptr<ceres::Manifold> manifold(newPoseManifold());
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus;
  manifold->PlusJacobian(block, plus.data());
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor>> j(jacobian,
                                                                                      rows, 7);
  return j * plus;
}

void expectNear(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected, double tolerance,
                const std::string& what) {
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.cols(), expected.cols());
  for (int r = 0; r < actual.rows(); ++r) {
    for (int c = 0; c < actual.cols(); ++c) {
      EXPECT_NEAR(actual(r, c), expected(r, c), tolerance * (1 + std::abs(expected(r, c))))
          << what << " (" << r << ", " << c << ")";
    }
  }
}

Rigid3d randomPose(std::mt19937& rng, double translation, double angle) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector3d t = drawVector<3>([&] { return n(rng); });
  const Eigen::Vector3d w = drawVector<3>([&] { return n(rng); });
  return Rigid3d(so3Exp(Eigen::Vector3d(w * angle)), t * translation);
}

// A time between two nodes 0.1 s apart whose corrections differ from the
// reference trajectory; ref_k / ref_k1: the reference at the nodes.
Bracket randomBracket(std::mt19937& rng, Rigid3d* ref_k, Rigid3d* ref_k1) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Bracket b;
  b.duration_s = 0.1;
  b.tau_ref_s = 0.1 * u(rng);
  *ref_k = randomPose(rng, 2.0, 0.3);
  *ref_k1 = *ref_k * randomPose(rng, 0.05, 0.02);
  b.ref_inverse_k = ref_k->inverse();
  b.ref_inverse_k1 = ref_k1->inverse();
  b.reference = *ref_k * randomPose(rng, 0.02, 0.01);
  return b;
}

// randomBracket with the robot moving through it (the reference's velocity
// and turn rate), for the tests that move tau.
Bracket randomMovingBracket(std::mt19937& rng, Rigid3d* ref_k, Rigid3d* ref_k1) {
  Bracket b = randomBracket(rng, ref_k, ref_k1);
  b.velocity_world = Eigen::Vector3d(0.8, -0.3, 0.01);
  b.omega_body = Eigen::Vector3d(0.01, -0.02, 0.3);
  return b;
}

// The drift model's anisotropy: a node displaced along the body's z (or
// tilted about x or y) is weighed by the vertical (tilt) sigma, the other
// axes by the horizontal (yaw) one.
TEST(JointCosts, RelativeMotionWeighsVerticalAndTiltByTheirRatios) {
  joint_detail::RelativeMotionCost cost;
  cost.delta_unscaled = Rigid3d();
  cost.sigma_t = 0.002;
  cost.sigma_r = 0.001;
  cost.vertical_ratio = 0.1;
  cost.tilt_ratio = 0.25;
  const double scale = 1.0;
  const double a[7] = {0, 0, 0, 0, 0, 0, 1};
  for (int axis = 0; axis < 6; ++axis) {
    Rigid3d moved;
    if (axis < 3) {
      moved.translation[axis] = 1e-3;
    } else {
      Eigen::Vector3d w = Eigen::Vector3d::Zero();
      w[axis - 3] = 1e-4;
      moved.rotation = so3Exp(w);
    }
    double b[7];
    poseToParams(moved, b);
    double r[6];
    ASSERT_TRUE(cost(a, b, &scale, r));
    const double sigma = axis == 2   ? 0.002 * 0.1
                         : axis < 2  ? 0.002
                         : axis == 5 ? 0.001
                                     : 0.001 * 0.25;
    for (int k = 0; k < 6; ++k) {
      EXPECT_NEAR(r[k], k == axis ? (axis < 3 ? 1e-3 : 1e-4) / sigma : 0.0, 1e-9)
          << "axis " << axis << ", residual " << k;
    }
  }
}

// The input trajectory's position smoothing: a constant acceleration (a
// quadratic in time) passes unchanged, white noise shrinks by the fit's
// factor, a gap separates what is fitted, orientations are kept.
TEST(JointCosts, SmoothPositionsKeepsAQuadraticAndShrinksNoise) {
  const TimeNs period = 33'333'333;  // 30 Hz
  auto at = [](double t) {
    return Eigen::Vector3d(0.8 * t + 0.15 * t * t, -0.3 * t * t, 0.01 * t);
  };
  std::mt19937 rng(testSeed(7));
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<StampedPose> clean, noisy;
  for (int i = 0; i < 300; ++i) {
    const TimeNs t = i * period + (i >= 150 ? 1'000'000'000 : 0);  // a 1 s gap after 150
    const double ts = static_cast<double>(t) * 1e-9;
    Rigid3d pose(so3Exp(Eigen::Vector3d(0.01 * ts, 0.0, 0.3 * ts)), at(ts));
    if (i >= 150) pose.translation += Eigen::Vector3d(5, 0, 0);  // the far side of the gap
    clean.push_back({t, pose});
    pose.translation += drawVector<3>([&] { return noise(rng); });
    noisy.push_back({t, pose});
  }
  const auto smoothed_clean = joint_detail::smoothPositions(clean, 0.2, 100'000'000);
  for (std::size_t i = 0; i < clean.size(); ++i) {
    EXPECT_NEAR(
        (smoothed_clean[i].world_from_body.translation - clean[i].world_from_body.translation)
            .norm(),
        0.0, 1e-9)
        << i;  // also at the gap: the jump of 5 m stays out of both sides' fits
    EXPECT_TRUE(smoothed_clean[i].world_from_body.rotation.isApprox(
        clean[i].world_from_body.rotation, 1e-15));
  }
  double before = 0, after = 0;
  const auto smoothed = joint_detail::smoothPositions(noisy, 0.2, 100'000'000);
  for (std::size_t i = 20; i + 20 < noisy.size(); ++i) {  // away from the ends
    if (i > 130 && i < 170) continue;                     // and from the gap
    before +=
        (noisy[i].world_from_body.translation - clean[i].world_from_body.translation).squaredNorm();
    after += (smoothed[i].world_from_body.translation - clean[i].world_from_body.translation)
                 .squaredNorm();
  }
  // 13 samples, quadratic: the centre's variance is 0.175 of a sample's.
  std::cout << "smoothed noise over the input's: " << std::sqrt(after / before) << "\n";
  EXPECT_LT(std::sqrt(after / before), 0.5);
  EXPECT_GT(std::sqrt(after / before), 0.3);
  // No smoothing asked: the input.
  const auto same = joint_detail::smoothPositions(noisy, 0.0, 100'000'000);
  EXPECT_EQ(same[5].world_from_body.translation, noisy[5].world_from_body.translation);
}

TEST(JointCosts, CachedBlobCostMatchesTheAutodiffReference) {
  const Camera fisheye =
      loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_640x360_calib_results.txt");
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int compared = 0;
  for (int trial = 0; trial < 50; ++trial) {
    Rigid3d ref_k, ref_k1;
    Bracket b = randomBracket(rng, &ref_k, &ref_k1);
    double nk[7], nk1[7], camera[7];
    poseToParams(ref_k * randomPose(rng, 0.01, 0.005), nk);
    poseToParams(ref_k1 * randomPose(rng, 0.01, 0.005), nk1);
    // A ceiling camera 3 m above the frame, within the fisheye's view.
    const Rigid3d world_from_fisheye = joint_detail::poseAt<double>(b, nk, nk1, b.tau_ref_s);
    const Eigen::Vector2d across = drawVector<2>([&] { return u(rng); });
    const Eigen::Vector3d in_fisheye(4 * (across.x() - 0.5), 4 * (across.y() - 0.5), 3.0);
    const Rigid3d world_from_camera(so3Exp(Eigen::Vector3d(3 * u(rng), 0.1, -0.2)),
                                    world_from_fisheye * in_fisheye);
    poseToParams(world_from_camera, camera);
    const Eigen::Vector3d offset(0.01, -0.02, 0.03);
    const Eigen::Vector2d observed =
        Eigen::Vector2d(320, 180) + 20 * drawVector<2>([&] { return u(rng); });

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
    // The analytic Jacobians differ from the autodiff ones along the
    // quaternions' norm, which the manifold never moves: compare what Ceres
    // uses, the products with the PlusJacobian.
    for (int blk = 0; blk < 3; ++blk) {
      expectNear(tangentJacobian(blocks[blk], j1[blk], 2), tangentJacobian(blocks[blk], j0[blk], 2),
                 1e-7, "trial " + std::to_string(trial) + " block " + std::to_string(blk));
    }
    // Residuals only, then a point with values but no Jacobians prepared.
    double r2[2];
    ASSERT_TRUE(cost.Evaluate(blocks, r2, nullptr));
    EXPECT_NEAR(r2[0], r0[0], 1e-9 * (1 + std::abs(r0[0])));
    ++compared;
  }
  EXPECT_EQ(compared, 50);
}

// A time outside its bracket (a clock offset moved it there during a round)
// takes the nearer node's correction, unamplified: the pose there is that
// correction times the reference, and the farther node has no influence.
// Extrapolated, the nodes' difference was amplified by the excursion, which
// let the 1,000-camera facility fit noise by running its clocks away.
TEST(JointCosts, TimeOutsideItsBracketHoldsTheNearerNodesCorrection) {
  std::mt19937 rng(8);
  for (int trial = 0; trial < 20; ++trial) {
    Rigid3d ref_k, ref_k1;
    const Bracket b = randomMovingBracket(rng, &ref_k, &ref_k1);
    double nk[7], nk1[7];
    const Rigid3d node_k = ref_k * randomPose(rng, 0.01, 0.005);
    const Rigid3d node_k1 = ref_k1 * randomPose(rng, 0.01, 0.005);
    poseToParams(node_k, nk);
    poseToParams(node_k1, nk1);
    for (const double tau : {-0.35, -0.01, 0.13, 2.0}) {
      const bool before = tau < 0;
      const Rigid3d correction = before ? node_k * b.ref_inverse_k : node_k1 * b.ref_inverse_k1;
      const double delta = tau - b.tau_ref_s;
      const Rigid3d reference(b.reference.rotation * so3Exp(Eigen::Vector3d(b.omega_body * delta)),
                              b.reference.translation + b.velocity_world * delta);
      const Rigid3d expected = correction * reference;
      const Rigid3d pose = joint_detail::poseAt<double>(b, nk, nk1, tau);
      EXPECT_LT((pose.translation - expected.translation).norm(), 1e-12) << tau;
      EXPECT_LT(pose.rotation.angularDistance(expected.rotation), 1e-12) << tau;
      // The farther node has no influence: the Jacobian on its tangent space is zero.
      joint_detail::PoseAtJacobian d;
      joint_detail::poseAtWithJacobian(b, nk, nk1, tau, &d);
      EXPECT_LT(d.middleCols<6>(before ? 6 : 0).norm(), 1e-9) << tau;
      // Tau still moves the pose with the reference's velocity.
      EXPECT_GT(d.col(12).head<3>().norm(), 0.5) << tau;
    }
  }
}

// The pose manifold's Jacobians written out against AutoDiffManifold's.
TEST(JointCosts, PoseManifoldMatchesAutodiff) {
  std::mt19937 rng(3);
  const ceres::AutoDiffManifold<RightPerturbedPose, 7, 6> reference;
  const std::unique_ptr<ceres::Manifold> manifold(newPoseManifold());
  for (int trial = 0; trial < 20; ++trial) {
    double x[7], delta[6] = {0.1, -0.2, 0.3, 0.02, -0.01, 0.03}, y0[7], y1[7], m0[6], m1[6];
    poseToParams(randomPose(rng, 2.0, 1.0), x);
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> p0, p1;
    Eigen::Matrix<double, 6, 7, Eigen::RowMajor> n0, n1;
    ASSERT_TRUE(reference.PlusJacobian(x, p0.data()));
    ASSERT_TRUE(manifold->PlusJacobian(x, p1.data()));
    ASSERT_TRUE(reference.MinusJacobian(x, n0.data()));
    ASSERT_TRUE(manifold->MinusJacobian(x, n1.data()));
    expectNear(p1, p0, 1e-12, "PlusJacobian");
    expectNear(n1, n0, 1e-12, "MinusJacobian");
    ASSERT_TRUE(reference.Plus(x, delta, y0));
    ASSERT_TRUE(manifold->Plus(x, delta, y1));
    ASSERT_TRUE(reference.Minus(y0, x, m0));
    ASSERT_TRUE(manifold->Minus(y1, x, m1));
    for (int i = 0; i < 7; ++i) EXPECT_EQ(y1[i], y0[i]);
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(m1[i], delta[i], 1e-12);
    EXPECT_EQ(manifold->AmbientSize(), 7);
    EXPECT_EQ(manifold->TangentSize(), 6);
  }
}

// poseAtWithJacobian against poseAt differentiated with Jets: the same pose,
// and the same derivatives with respect to the nodes' tangents and to tau,
// inside the bracket, at its ends and outside it; and at rotations between
// the nodes up to 2.5 rad.
TEST(JointCosts, PoseAtJacobianMatchesJets) {
  std::mt19937 rng(21);
  const std::unique_ptr<ceres::Manifold> manifold(newPoseManifold());
  int compared = 0;
  for (int trial = 0; trial < 40; ++trial) {
    Rigid3d ref_k, ref_k1;
    const Bracket b = randomMovingBracket(rng, &ref_k, &ref_k1);
    double nk[7], nk1[7];
    const double spread = trial < 20 ? 0.005 : 0.5;  // the nodes' rotations apart
    poseToParams(ref_k * randomPose(rng, 0.01, spread), nk);
    poseToParams(ref_k1 * randomPose(rng, 0.01, spread), nk1);
    for (const double tau : {-0.05, 0.0, 0.013, 0.061, 0.1, 0.3}) {
      joint_detail::PoseAtJacobian d;
      const Rigid3d pose = joint_detail::poseAtWithJacobian(b, nk, nk1, tau, &d);
      using J = ceres::Jet<double, 15>;
      J a[7], c[7];
      for (int i = 0; i < 7; ++i) {
        a[i] = J(nk[i], i);
        c[i] = J(nk1[i], 7 + i);
      }
      const Rigid3<J> jet = joint_detail::poseAt(b, a, c, J(tau, 14));
      Eigen::Matrix<double, 7, 15, Eigen::RowMajor> stored;  // d [t q] / d [nk nk1 tau]
      const J out[7] = {jet.translation.x(),      jet.translation.y(),
                        jet.translation.z(),      jet.rotation.coeffs()[0],
                        jet.rotation.coeffs()[1], jet.rotation.coeffs()[2],
                        jet.rotation.coeffs()[3]};
      for (int r = 0; r < 7; ++r) stored.row(r) = out[r].v.transpose();
      EXPECT_LT((pose.translation - Eigen::Vector3d(out[0].a, out[1].a, out[2].a)).norm(), 1e-12);
      EXPECT_NEAR(std::abs(pose.rotation.coeffs().dot(
                      Eigen::Vector4d(out[3].a, out[4].a, out[5].a, out[6].a))),
                  1.0, 1e-12);
      // Jets give d[t q]; the pose's tangent is [dt; 2 (q^-1 dq).vec].
      Eigen::Matrix<double, 6, 7> to_tangent = Eigen::Matrix<double, 6, 7>::Zero();
      to_tangent.block<3, 3>(0, 0).setIdentity();
      for (int i = 0; i < 4; ++i) {
        Eigen::Quaterniond e(0, 0, 0, 0);
        e.coeffs()[i] = 1;
        to_tangent.block<3, 1>(3, 3 + i) = 2 * (pose.rotation.conjugate() * e).vec();
      }
      Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_k, plus_k1;
      manifold->PlusJacobian(nk, plus_k.data());
      manifold->PlusJacobian(nk1, plus_k1.data());
      const std::string what = "trial " + std::to_string(trial) + " tau " + std::to_string(tau);
      expectNear(d.middleCols<6>(0), to_tangent * stored.middleCols<7>(0) * plus_k, 1e-9,
                 what + " node_k");
      expectNear(d.middleCols<6>(6), to_tangent * stored.middleCols<7>(7) * plus_k1, 1e-9,
                 what + " node_k+1");
      expectNear(d.col(12), to_tangent * stored.col(14), 1e-9, what + " tau");
      ++compared;
    }
  }
  EXPECT_EQ(compared, 240);
}

// The marker costs with their derivatives written out against the autodiff
// structs: same residuals, same tangent Jacobians (poses and corners).
TEST(JointCosts, AnalyticMarkerCostsMatchTheAutodiffReference) {
  const Camera camera_model =
      loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_640x360_calib_results.txt");
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int compared = 0;
  for (int trial = 0; trial < 50; ++trial) {
    Rigid3d ref_k, ref_k1;
    const Bracket b = randomMovingBracket(rng, &ref_k, &ref_k1);
    double nk[7], nk1[7], x[7], camera[7], offset = 0.004 * (u(rng) - 0.5);
    poseToParams(ref_k * randomPose(rng, 0.01, 0.005), nk);
    poseToParams(ref_k1 * randomPose(rng, 0.01, 0.005), nk1);
    const Rigid3d fisheye_from_marker(so3Exp(Eigen::Vector3d(0.02, -0.01, 1.5 * u(rng))),
                                      Eigen::Vector3d(0.01, -0.15, -0.05));
    poseToParams(fisheye_from_marker, x);
    const double tau = 0.1 * u(rng);
    // A camera 3 m above the marker, looking down at it.
    const Rigid3d world_from_marker =
        joint_detail::poseAt<double>(b, nk, nk1, tau - offset) * fisheye_from_marker;
    const double roll = M_PI + 0.2 * (u(rng) - 0.5);  // the right operand first, as gcc did
    const double yaw = 3 * u(rng);
    const Rigid3d down(so3Exp(Eigen::Vector3d(0, 0, yaw)) * so3Exp(Eigen::Vector3d(roll, 0.1, 0)),
                       Eigen::Vector3d::Zero());
    const Eigen::Vector2d offset_xy = drawVector<2>([&] { return u(rng); });
    const Rigid3d world_from_camera(
        down.rotation,
        world_from_marker * Eigen::Vector3d(0.3 * offset_xy.x(), 0.2 * offset_xy.y(), 0.0) +
            Eigen::Vector3d(0, 0, 3.0));
    poseToParams(world_from_camera, camera);
    const Rigid3d measured =
        world_from_camera.inverse() * world_from_marker * randomPose(rng, 0.01, 0.02);

    joint_detail::MarkerPoseCost pose;
    pose.bracket = b;
    pose.tau_camera_s = tau;
    pose.measured = measured;
    Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Random();
    pose.sqrt_info = 50 * Eigen::Matrix<double, 6, 6>::Identity() + a;
    joint_detail::MarkerCornersCost corners;
    corners.bracket = b;
    corners.tau_camera_s = tau;
    corners.camera_model = &camera_model;
    const double h = 0.1;
    corners.corners_in_marker = {Eigen::Vector3d(-h, h, 0), Eigen::Vector3d(h, h, 0),
                                 Eigen::Vector3d(h, -h, 0), Eigen::Vector3d(-h, -h, 0)};
    for (int c = 0; c < 4; ++c)
      corners.observed[c] = Eigen::Vector2d(300, 170) + drawVector<2>([&] {
                                                          return u(rng);
                                                        }).cwiseProduct(Eigen::Vector2d(40, 20));
    corners.sigma_px = 0.3;

    const double* blocks[5] = {nk, nk1, x, camera, &offset};
    auto compare = [&](const ceres::CostFunction& expected_cost, const ceres::CostFunction& cost,
                       int rows, const std::string& what) {
      std::vector<double> r0(rows), r1(rows), r2(rows);
      std::vector<std::vector<double>> j0(5, std::vector<double>(rows * 7)), j1 = j0;
      double* jac0[5];
      double* jac1[5];
      for (int k = 0; k < 5; ++k) {
        jac0[k] = j0[k].data();
        jac1[k] = j1[k].data();
      }
      ASSERT_TRUE(expected_cost.Evaluate(blocks, r0.data(), jac0)) << what;
      ASSERT_TRUE(cost.Evaluate(blocks, r1.data(), jac1)) << what;
      ASSERT_TRUE(cost.Evaluate(blocks, r2.data(), nullptr)) << what;
      for (int i = 0; i < rows; ++i) {
        EXPECT_NEAR(r1[i], r0[i], 1e-9 * (1 + std::abs(r0[i]))) << what;
        EXPECT_NEAR(r2[i], r0[i], 1e-9 * (1 + std::abs(r0[i]))) << what;
      }
      for (int k = 0; k < 4; ++k) {
        expectNear(tangentJacobian(blocks[k], j1[k].data(), rows),
                   tangentJacobian(blocks[k], j0[k].data(), rows), 1e-7,
                   what + " block " + std::to_string(k));
      }
      expectNear(Eigen::Map<Eigen::VectorXd>(j1[4].data(), rows),
                 Eigen::Map<Eigen::VectorXd>(j0[4].data(), rows), 1e-7, what + " offset");
    };
    const ceres::AutoDiffCostFunction<joint_detail::MarkerPoseCost, 6, 7, 7, 7, 7, 1> pose_ad(
        new joint_detail::MarkerPoseCost(pose));
    compare(pose_ad, joint_detail::AnalyticMarkerPoseCost(pose), 6,
            "pose trial " + std::to_string(trial));
    const ceres::AutoDiffCostFunction<joint_detail::MarkerCornersCost, 8, 7, 7, 7, 7, 1> corners_ad(
        new joint_detail::MarkerCornersCost(corners));
    compare(corners_ad, joint_detail::AnalyticMarkerCornersCost(corners), 8,
            "corners trial " + std::to_string(trial));
    ++compared;
  }
  EXPECT_EQ(compared, 50);
}

TEST(JointCosts, CacheRecomputesAtANewPointAndWhenJacobiansAreAskedLater) {
  Bracket b;
  b.duration_s = 0.1;
  b.tau_ref_s = 0.04;
  double nk[7], nk1[7];
  poseToParams(Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0)), nk);
  poseToParams(Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(2, 0, 0)), nk1);
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
  EXPECT_NEAR(cache.jacobian(slot)(0, 6), 0.4, 1e-12);  // d x / d node_k+1.x
  nk[0] = 0;
  cache.PrepareForEvaluation(false, true);
  EXPECT_NEAR(cache.pose(slot)[0], 1.2, 1e-12);
}

}  // namespace

// The clock search of a camera look_down could not register: the configured
// offset (shift 0) stays while the detections agree there (its spread is
// admissible: the blobs along a path not yet corrected cannot tell a clock
// offset from the odometry's drift), or unless another is clearly better, by
// the blobs where there are scores, else by the detections' spread.
TEST(JointClockSearch, KeepsTheConfiguredOffsetUnlessAnotherIsClearlyBetter) {
  const std::vector<double> shifts = {-0.01, 0.0, 0.01};
  const double none = std::numeric_limits<double>::quiet_NaN();
  // Spreads alike and no blobs: 0 stays although -0.01 spreads least.
  EXPECT_EQ(joint_detail::chooseShift(shifts, {0.010, 0.011, 0.012}, {none, none, none}), 1u);
  // One spread 25x smaller: it wins (the others are not even admissible).
  EXPECT_EQ(joint_detail::chooseShift(shifts, {0.002, 0.05, 0.06}, {none, none, none}), 0u);
  // The detections agree at 0: it stays whatever the blobs say.
  EXPECT_EQ(joint_detail::chooseShift(shifts, {0.010, 0.011, 0.012}, {5.0, 3.0, 0.5}), 1u);
  // They do not: the blobs decide among the admissible spreads, and 0.5 px
  // beats 0's 3 px by more than 1 px; 2.5 px does not.
  EXPECT_EQ(joint_detail::chooseShift(shifts, {0.010, 0.05, 0.012}, {5.0, 3.0, 0.5}), 2u);
  EXPECT_EQ(joint_detail::chooseShift(shifts, {0.010, 0.05, 0.012}, {5.0, 3.0, 2.5}), 1u);
  // Among the other shifts, one with a blob score beats one without; the
  // configured offset stays against it, unless its spread is 1.5x larger
  // and not admissible.
  EXPECT_EQ(joint_detail::chooseShift({-0.01, 0.01}, {0.010, 0.010}, {none, 4.0}), 1u);
  EXPECT_EQ(joint_detail::chooseShift({0.0, 0.01}, {0.010, 0.010}, {none, 4.0}), 0u);
  EXPECT_EQ(joint_detail::chooseShift({0.0, 0.01}, {0.016, 0.010}, {none, 4.0}), 0u);
  EXPECT_EQ(joint_detail::chooseShift({0.0, 0.01}, {0.05, 0.010}, {none, 4.0}), 1u);
}

// A detection's rotation is the marker's, noisy by degrees; its position in
// the camera is good. Sharing the mean rotation removes what the rotation
// noise does to the camera positions: noise-free positions come back.
TEST(JointClockSearch, SharedRotationRemovesTheMarkersRotationNoise) {
  std::mt19937 rng(testSeed(5));
  std::normal_distribution<double> deg(0.0, 2.0 * M_PI / 180.0);
  const Rigid3d world_from_camera(so3Exp(Eigen::Vector3d(3.1, 0.05, -0.4)),
                                  Eigen::Vector3d(4.0, -2.0, 3.2));
  std::vector<Rigid3d> candidates;
  std::vector<Eigen::Vector3d> marker_in_camera;
  for (int i = 0; i < 9; ++i) {
    const Eigen::Vector3d m(0.3 * (i % 3) - 0.3, 0.2 * (i / 3) - 0.2, 2.9);
    const Eigen::Vector3d w = drawVector<3>([&] { return deg(rng); });
    // Rotated about the marker: the marker stays where the camera saw it.
    const Eigen::Vector3d marker_in_world = world_from_camera * m;
    const Eigen::Quaterniond rotation = so3Exp(w) * world_from_camera.rotation;
    candidates.emplace_back(rotation, marker_in_world - rotation * m);
    marker_in_camera.push_back(m);
  }
  // A symmetric set: the mean rotation is the true one.
  for (int i = 0; i < 9; ++i) {
    const Eigen::Vector3d m = marker_in_camera[static_cast<std::size_t>(i)];
    const Eigen::Quaterniond back = world_from_camera.rotation *
                                    candidates[static_cast<std::size_t>(i)].rotation.conjugate() *
                                    world_from_camera.rotation;
    const Eigen::Vector3d marker_in_world = world_from_camera * m;
    candidates.emplace_back(back, marker_in_world - back * m);
    marker_in_camera.push_back(m);
  }
  const Eigen::Vector3d before = joint_detail::medianPosition(candidates);
  EXPECT_GT(joint_detail::medianDistance(candidates, before), 0.05);
  joint_detail::shareMeanRotation(candidates, marker_in_camera);
  const Eigen::Vector3d after = joint_detail::medianPosition(candidates);
  EXPECT_LT((after - world_from_camera.translation).norm(), 1e-9);
  EXPECT_LT(joint_detail::medianDistance(candidates, after), 1e-9);
  EXPECT_EQ(joint_detail::medianDistance({}, after), std::numeric_limits<double>::infinity());
}

}  // namespace lookboth
