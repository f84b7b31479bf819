// The global bundle adjustment in windows (bounded memory) against the one
// problem over all keyframes, on a noise-free synthetic ceiling.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "../src/map.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/sim3.h"
#include "lookboth/geometry/umeyama.h"

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
    kf.world_from_camera =
        Rigid3d(e.rotation * kf.world_from_camera.rotation *
                    so3Exp(Eigen::Vector3d(Eigen::Vector3d(n(rng), n(rng), n(rng)) / 4)),
                e * kf.world_from_camera.translation + Eigen::Vector3d(n(rng), n(rng), n(rng)));
  }
  // (A point seen once is held where it is by the adjustment: left exact.)
  for (Landmark& l : s.perturbed.landmarks) {
    if (l.observations.size() < 2) continue;
    l.p_in_world = error[size_t(l.reference_keyframe)] * l.p_in_world +
                   Eigen::Vector3d(n(rng), n(rng), n(rng));
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

}  // namespace
}  // namespace lookboth::vo
