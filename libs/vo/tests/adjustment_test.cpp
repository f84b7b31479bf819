// The global bundle adjustment in windows (bounded memory) against the one
// problem over all keyframes, on a noise-free synthetic ceiling.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "../src/map.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"
#include "lookboth/geometry/sim3.h"
#include "lookboth/geometry/umeyama.h"
#include "lookboth/vo/bearing_geometry.h"

namespace lookboth::vo {
namespace {

struct Scene {
  Map truth;
  Map perturbed;
};

// `keyframes` upward-looking keyframes 0.2 m apart along x under a ceiling
// of points 3.5 m above on a 0.25 m grid; each sees the points within 3 m
// horizontally (exact bearings). The estimate starts from poses and points
// with a drift and noise of sigma_m (and sigma_m / 4 rad of rotation),
// keyframe 0 exact.
Scene makeScene(int keyframes, double sigma_m, double drift, unsigned seed) {
  Scene s;
  Map& m = s.truth;
  const double length = 0.2 * (keyframes - 1);
  for (int k = 0; k < keyframes; ++k) {
    Keyframe kf;
    kf.id = k;
    kf.t = k;
    // A gentle sway so that the path is not a straight line.
    const double x = 0.2 * k;
    const Eigen::Vector3d c(x, 0.5 * std::sin(x / 3.0), 0.0);
    kf.world_from_camera =
        Rigid3d(so3Exp(Eigen::Vector3d(0.02 * std::sin(x), 0.02 * std::cos(x), 0.3 * x / 10)), c);
    m.keyframes.push_back(kf);
  }
  for (double x = -3; x <= length + 3; x += 0.25) {
    for (double y = -3.5; y <= 3.5; y += 0.25) {
      // A ceiling with some relief (beams), not a perfect plane.
      const double z = 3.5 + 0.3 * (std::fmod(std::abs(x), 2.0) < 0.25 ? 1 : 0);
      const int l = m.addLandmark(Eigen::Vector3d(x, y, z), -1);
      for (Keyframe& kf : m.keyframes) {
        const Eigen::Vector3d p = m.landmarks[size_t(l)].p_in_world;
        if ((p.head<2>() - kf.world_from_camera.translation.head<2>()).norm() > 3.0) continue;
        if (m.landmarks[size_t(l)].reference_keyframe < 0)
          m.landmarks[size_t(l)].reference_keyframe = kf.id;
        m.observe(l, kf.id, (kf.world_from_camera.inverse() * p).normalized());
      }
    }
  }
  s.perturbed = m;
  // The errors of an odometry: a drift that grows along the path (scale 1 +
  // drift, yaw drift * 0.5 rad, a lateral bend) plus sigma_m of noise per
  // keyframe; the points follow the keyframe that first saw them.
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, sigma_m);
  std::vector<Sim3d> error(static_cast<size_t>(keyframes));
  for (int k = 0; k < keyframes; ++k) {
    const double u = double(k) / (keyframes - 1);
    // A similarity about the first keyframe's position that grows with u.
    const Sim3d about(1.0 + drift * u,
                      Eigen::Quaterniond(so3Exp(Eigen::Vector3d(0, 0, 0.5 * drift * u))),
                      Eigen::Vector3d(0, drift * u * u * length, 0));
    error[size_t(k)] = k == 0 ? Sim3d() : about;
  }
  for (Keyframe& kf : s.perturbed.keyframes) {
    if (kf.id == 0) continue;
    const Sim3d& e = error[size_t(kf.id)];
    const Eigen::Vector3d dt = drawVector<3>([&] { return n(rng); });
    const Eigen::Vector3d dr = drawVector<3>([&] { return n(rng); }) / 4;
    kf.world_from_camera = Rigid3d(e.rotation * kf.world_from_camera.rotation * so3Exp(dr),
                                   e * kf.world_from_camera.translation + dt);
  }
  // (A point seen once is held where it is by the adjustment: left exact.)
  for (Landmark& l : s.perturbed.landmarks) {
    if (l.observations.size() < 2) continue;
    l.p_in_world =
        error[size_t(l.reference_keyframe)] * l.p_in_world + drawVector<3>([&] { return n(rng); });
  }
  return s;
}

// RMS keyframe position error after a similarity alignment (the scale of a
// monocular adjustment is free) [m].
double alignedError(const Map& estimate, const Map& truth) {
  std::vector<Eigen::Vector3d> src, dst;
  for (size_t k = 0; k < truth.keyframes.size(); ++k) {
    src.push_back(estimate.keyframes[k].world_from_camera.translation);
    dst.push_back(truth.keyframes[k].world_from_camera.translation);
  }
  const auto a = alignSim3(src, dst);
  EXPECT_TRUE(a.has_value());
  return a ? a->rms_error : 1e9;
}

std::set<int> allKeyframes(const Map& m) {
  std::set<int> ids;
  for (const Keyframe& kf : m.keyframes) ids.insert(kf.id);
  return ids;
}

AdjustmentOptions options() {
  AdjustmentOptions o;
  o.focal_px = 300;
  o.iterations = 100;
  o.outlier_px = 1e6;  // Noise-free: nothing is an outlier.
  return o;
}

TEST(GlobalAdjustmentTest, OneProblemRecoversNoiseFreeSceneTo1e6) {
  Scene s = makeScene(60, 0.01, 0.05, 3);
  const double before = alignedError(s.perturbed, s.truth);
  bundleAdjustWindowed(s.perturbed, allKeyframes(s.perturbed), 0, 0, 1, options());
  const double after = alignedError(s.perturbed, s.truth);
  EXPECT_GT(before, 5e-3);
  EXPECT_LT(after, 1e-6);
}

TEST(GlobalAdjustmentTest, WindowAtLeastTheSegmentIsTheOneProblem) {
  Scene a = makeScene(40, 0.01, 0.05, 4);
  Scene b = a;
  bundleAdjustWindowed(a.perturbed, allKeyframes(a.perturbed), 0, 0, 1, options());
  bundleAdjustWindowed(b.perturbed, allKeyframes(b.perturbed), 0, 40, 2, options());
  for (size_t k = 0; k < a.perturbed.keyframes.size(); ++k) {
    EXPECT_EQ(a.perturbed.keyframes[k].world_from_camera.translation,
              b.perturbed.keyframes[k].world_from_camera.translation);
  }
}

TEST(GlobalAdjustmentTest, WindowsMoveEveryKeyframeAndApproachTheOneProblem) {
  Scene s = makeScene(100, 0.002, 0.05, 5);
  const double before = alignedError(s.perturbed, s.truth);
  Map windowed = s.perturbed;
  bundleAdjustWindowed(windowed, allKeyframes(windowed), 0, 24, 6, options());
  const double after = alignedError(windowed, s.truth);
  // Every keyframe but the gauge was adjusted (none left where it started).
  for (size_t k = 1; k < windowed.keyframes.size(); ++k) {
    EXPECT_NE(windowed.keyframes[k].world_from_camera.translation,
              s.perturbed.keyframes[k].world_from_camera.translation)
        << "keyframe " << k;
  }
  EXPECT_EQ(windowed.keyframes[0].world_from_camera.translation,
            s.truth.keyframes[0].world_from_camera.translation);
  Map coarse = s.perturbed;
  bundleAdjustWindowed(coarse, allKeyframes(coarse), 0, 24, 0, options());
  const double coarse_only = alignedError(coarse, s.truth);
  std::printf("aligned keyframe error: before %.3e m, coarse step only %.3e m, windowed %.3e m\n",
              before, coarse_only, after);
  // The coarse step takes out most of the drift, the windows most of the rest.
  EXPECT_LT(coarse_only, 0.05 * before);
  EXPECT_LT(after, 0.5 * coarse_only);
  EXPECT_LT(after, 0.02 * before);
}

TEST(GlobalAdjustmentTest, WithinTheBudgetTheSampledAdjustmentIsTheOneProblem) {
  Scene a = makeScene(40, 0.01, 0.05, 8);
  Scene b = a;
  Scene c = a;
  AdjustmentReport one;
  bundleAdjust(a.perturbed, allKeyframes(a.perturbed), {0}, options(), ObservationScope::kAll,
               &one);
  ObservationBudget budget;
  budget.max_observations = one.largest_residual_blocks;
  budget.min_per_keyframe = 40;
  AdjustmentReport report;
  bundleAdjustSampled(b.perturbed, allKeyframes(b.perturbed), 0, budget, options(), &report);
  EXPECT_EQ(report.largest_residual_blocks, one.largest_residual_blocks);
  // One observation fewer: a subset.
  --budget.max_observations;
  AdjustmentReport subset;
  bundleAdjustSampled(c.perturbed, allKeyframes(c.perturbed), 0, budget, options(), &subset);
  EXPECT_LT(subset.largest_residual_blocks, one.largest_residual_blocks);
  for (size_t k = 0; k < a.perturbed.keyframes.size(); ++k) {
    EXPECT_EQ(a.perturbed.keyframes[k].world_from_camera.translation,
              b.perturbed.keyframes[k].world_from_camera.translation);
  }
}

// Over the budget: one problem over every keyframe on a subset of the
// landmarks still recovers the noise-free scene from a 5 % drift.
TEST(GlobalAdjustmentTest, SampledAdjustmentRecoversNoiseFreeSceneFromDrift) {
  Scene s = makeScene(100, 0.002, 0.05, 9);
  Map copy = s.perturbed;
  AdjustmentReport one;
  bundleAdjust(copy, allKeyframes(copy), {0}, options(), ObservationScope::kAll, &one);
  const int all = one.largest_residual_blocks;
  ObservationBudget budget;
  budget.max_observations = 6000;  // 60 per keyframe
  budget.min_per_keyframe = 40;
  const double before = alignedError(s.perturbed, s.truth);
  AdjustmentReport report;
  bundleAdjustSampled(s.perturbed, allKeyframes(s.perturbed), 0, budget, options(), &report);
  const double after = alignedError(s.perturbed, s.truth);
  std::printf("aligned keyframe error: before %.3e m, sampled %.3e m (%d of %d observations)\n",
              before, after, report.largest_residual_blocks, all);
  EXPECT_GT(all, 5 * budget.max_observations);
  EXPECT_EQ(report.problems, 1);
  EXPECT_EQ(report.largest_keyframes, 100);
  // Whole landmarks are taken (here seen by ~30 keyframes each): the
  // problem overshoots the budget (x2 here; x1.2 on `revisit x2`).
  EXPECT_LT(report.largest_residual_blocks, 2.5 * budget.max_observations);
  EXPECT_GT(before, 0.05);
  // (The implicit Schur complement's conjugate gradients stop short of the
  // direct solve: 2e-6 m here, the factorisation 2e-11 m.)
  EXPECT_LT(after, 1e-5);
  // The landmarks left out followed their keyframes: the map still fits the
  // keyframes (median angular error of all observations).
  std::vector<double> errors;
  for (const Landmark& l : s.perturbed.landmarks) {
    if (!l.valid || l.observations.size() < 2) continue;
    for (const Observation& o : l.observations) {
      const Rigid3d camera_from_world =
          s.perturbed.keyframes[size_t(o.keyframe)].world_from_camera.inverse();
      errors.push_back(angularError(o.bearing, camera_from_world * l.p_in_world));
    }
  }
  std::nth_element(errors.begin(), errors.begin() + long(errors.size() / 2), errors.end());
  EXPECT_LT(errors[errors.size() / 2] * options().focal_px, 2.0) << "px";
}

// The largest problem does not grow with the segment over the budget (until
// min_per_keyframe binds); the one problem's grows with it (its memory:
// ~180 KB per keyframe on `paper`).
TEST(GlobalAdjustmentTest, SampledProblemDoesNotGrowWithTheSegment) {
  AdjustmentReport one[2], sampled[2];
  const int lengths[2] = {80, 160};
  ObservationBudget budget;
  budget.max_observations = 6000;
  budget.min_per_keyframe = 20;
  for (int i = 0; i < 2; ++i) {
    Scene s = makeScene(lengths[i], 0.002, 0.0, 10);
    Map copy = s.perturbed;
    bundleAdjustSampled(copy, allKeyframes(copy), 0, ObservationBudget(), options(), &one[i]);
    bundleAdjustSampled(s.perturbed, allKeyframes(s.perturbed), 0, budget, options(), &sampled[i]);
  }
  std::printf("largest problem, observations: one problem %d -> %d, sampled %d -> %d\n",
              one[0].largest_residual_blocks, one[1].largest_residual_blocks,
              sampled[0].largest_residual_blocks, sampled[1].largest_residual_blocks);
  EXPECT_GT(one[1].largest_residual_blocks, 1.8 * one[0].largest_residual_blocks);
  EXPECT_LT(sampled[1].largest_residual_blocks, 1.1 * sampled[0].largest_residual_blocks);
  EXPECT_LT(sampled[1].largest_residual_blocks, 2.5 * budget.max_observations);
  EXPECT_EQ(sampled[1].largest_keyframes, 160);
}

}  // namespace
}  // namespace lookboth::vo
