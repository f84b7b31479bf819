#include "lookboth/geometry/trajectory.h"

#include <gtest/gtest.h>
#include <mrpt/poses/CPose3DInterpolator.h>

#include "lookboth/core/error.h"
#include "lookboth/geometry/pose_conversions.h"
#include "test_utils.h"

namespace lookboth {
namespace {

Trajectory makeTrajectory(std::mt19937& rng, int n, TimeNs step,
                          TimeNs start = secondsToNs(1700000000)) {
  Trajectory trajectory;
  Rigid3d pose = testing::randomPose(rng);
  for (int i = 0; i < n; ++i) {
    Eigen::Matrix<double, 6, 1> delta;
    std::normal_distribution<double> noise(0.0, 0.1);
    for (int k = 0; k < 6; ++k) delta[k] = noise(rng);
    pose = pose * se3Exp(delta);
    trajectory.append(start + i * step, pose);
  }
  return trajectory;
}

TEST(Trajectory, InterpolationIsExactOnSamples) {
  std::mt19937 rng(21);
  const Trajectory trajectory = makeTrajectory(rng, 50, millisecondsToNs(33));
  for (const StampedPose& s : trajectory.samples()) {
    const InterpolationResult r = trajectory.interpolate(s.t, millisecondsToNs(100));
    ASSERT_TRUE(r.ok());
    EXPECT_EQ(r.world_from_body.translation, s.world_from_body.translation);
    EXPECT_EQ(r.world_from_body.rotation.coeffs(), s.world_from_body.rotation.coeffs());
  }
}

TEST(Trajectory, SlerpsMidwayBetweenSamples) {
  Trajectory trajectory;
  trajectory.append(0, Rigid3d());
  trajectory.append(1000,
                    Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitX())),
                            Eigen::Vector3d(1.0, -2.0, 4.0)));
  const InterpolationResult r = trajectory.interpolate(250, 0);
  ASSERT_TRUE(r.ok());
  EXPECT_LT((r.world_from_body.translation - Eigen::Vector3d(0.25, -0.5, 1.0)).norm(), 1e-15);
  EXPECT_LT(rotationAngleBetween(r.world_from_body.rotation, Eigen::Quaterniond(Eigen::AngleAxisd(
                                                                 0.25, Eigen::Vector3d::UnitX()))),
            1e-12);
  EXPECT_EQ(r.t_before, 0);
  EXPECT_EQ(r.t_after, 1000);
}

TEST(Trajectory, NeverExtrapolates) {
  Trajectory trajectory;
  EXPECT_EQ(trajectory.interpolate(5, 0).status, InterpolationStatus::kEmpty);
  trajectory.append(100, Rigid3d());
  trajectory.append(200, Rigid3d());
  trajectory.append(1000, Rigid3d());
  EXPECT_EQ(trajectory.interpolate(99, 0).status, InterpolationStatus::kBeforeStart);
  EXPECT_EQ(trajectory.interpolate(1001, 0).status, InterpolationStatus::kAfterEnd);
  EXPECT_EQ(trajectory.interpolate(500, 300).status, InterpolationStatus::kGapTooLong);
  EXPECT_TRUE(trajectory.interpolate(150, 300).ok());
  EXPECT_TRUE(trajectory.interpolate(500, 0).ok());     // no gap limit
  EXPECT_TRUE(trajectory.interpolate(1000, 300).ok());  // on a sample: no gap involved
  EXPECT_STREQ(interpolationStatusName(InterpolationStatus::kGapTooLong),
               "inside a gap between samples");
}

TEST(Trajectory, RejectsDuplicateAndUnorderedTimestamps) {
  Trajectory trajectory;
  trajectory.append(100, Rigid3d());
  EXPECT_THROW(trajectory.append(100, Rigid3d()), Error);
  EXPECT_THROW(trajectory.append(50, Rigid3d()), Error);
  EXPECT_THROW(Trajectory({{10, Rigid3d()}, {5, Rigid3d()}}), Error);
}

// Cross-check with MRPT's linear+slerp interpolator on the same samples.
// MRPT 2.5.8's CPose3DInterpolator computes its interpolation ratio with
// about 1e-5 relative error (it returns x = 1.4999905 midway between x = 1 and
// x = 2: measured, see doc/conventions.md), so agreement is checked relative
// to the motion between the two samples; exactness of our own interpolation
// is checked by SlerpsMidwayBetweenSamples.
TEST(Trajectory, AgreesWithMrptLinearSlerpInterpolator) {
  std::mt19937 rng(22);
  const TimeNs step = millisecondsToNs(100);
  const Trajectory trajectory = makeTrajectory(rng, 30, step, secondsToNs(10));
  mrpt::poses::CPose3DInterpolator mrpt_interpolator;
  mrpt_interpolator.setInterpolationMethod(mrpt::poses::imLinearSlerp);
  for (const StampedPose& s : trajectory.samples()) {
    mrpt_interpolator.insert(toMrptTime(s.t), toMrptPose(s.world_from_body).asTPose());
  }
  std::uniform_int_distribution<TimeNs> u(trajectory.startTime(), trajectory.endTime());
  for (int i = 0; i < 200; ++i) {
    const TimeNs t = u(rng) / 100 * 100;
    const InterpolationResult ours = trajectory.interpolate(t, 0);
    ASSERT_TRUE(ours.ok());
    mrpt::math::TPose3D theirs;
    bool valid = false;
    mrpt_interpolator.interpolate(toMrptTime(t), theirs, valid);
    ASSERT_TRUE(valid);
    const Rigid3d theirs_rigid = fromMrptPose(mrpt::poses::CPose3D(theirs));
    const auto before = trajectory.interpolate(ours.t_before, 0).world_from_body;
    const auto after = trajectory.interpolate(ours.t_after, 0).world_from_body;
    const double kRatioError = 3e-5;
    EXPECT_LE(testing::translationError(ours.world_from_body, theirs_rigid),
              kRatioError * testing::translationError(before, after) + 1e-9);
    EXPECT_LE(testing::rotationError(ours.world_from_body, theirs_rigid),
              kRatioError * testing::rotationError(before, after) + 1e-9);
  }
}

// A keyframe trajectory's intervals are its sampling, not gaps: the limit
// grows to ten times the median interval; a dense trajectory keeps the
// configured one, and a lost stretch in it is still a gap.
TEST(Trajectory, EffectiveMaxGapFollowsTheSampling) {
  Trajectory dense, keyframes;
  for (int i = 0; i < 100; ++i) dense.append(millisecondsToNs(33) * i, Rigid3d());
  dense.append(millisecondsToNs(33) * 99 + secondsToNs(2), Rigid3d());
  const TimeNs limit = millisecondsToNs(500);
  EXPECT_EQ(dense.medianInterval(), millisecondsToNs(33));
  EXPECT_EQ(effectiveMaxGap(dense, limit), limit);
  EXPECT_EQ(
      dense.interpolate(millisecondsToNs(33) * 99 + secondsToNs(1), effectiveMaxGap(dense, limit))
          .status,
      InterpolationStatus::kGapTooLong);
  const TimeNs intervals[] = {300, 400, 350, 1200, 380, 2500, 360};  // [ms]
  TimeNs t = 0;
  keyframes.append(t, Rigid3d());
  for (TimeNs ms : intervals) keyframes.append(t += millisecondsToNs(ms), Rigid3d());
  EXPECT_EQ(keyframes.medianInterval(), millisecondsToNs(380));
  EXPECT_EQ(effectiveMaxGap(keyframes, limit), millisecondsToNs(3800));
  EXPECT_TRUE(
      keyframes.interpolate(t - millisecondsToNs(1000), effectiveMaxGap(keyframes, limit)).ok());
  EXPECT_EQ(effectiveMaxGap(keyframes, 0), 0);  // no limit stays no limit
  EXPECT_EQ(Trajectory().medianInterval(), 0);
}

}  // namespace
}  // namespace lookboth
