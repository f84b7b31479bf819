// The robot's motion: speed and acceleration limits, smoothness, a loop
// that closes, the configured length, small roll and pitch.
#include <gtest/gtest.h>

#include <cmath>

#include "lookboth/core/error.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/sim/motion.h"

namespace lookboth::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

MotionSpec rectangleSpec() {
  MotionSpec spec;
  spec.loop = {{2, 2}, {10, 2}, {10, 6}, {2, 6}};
  spec.max_speed_mps = 1.0;
  spec.max_acceleration_mps2 = 0.3;
  spec.max_lateral_acceleration_mps2 = 0.3;
  spec.laps = 2;
  return spec;
}

MotionSpec combSpec() {
  MotionSpec spec;
  // The rounded corners shorten the loop by (2 - pi/2) r each; 16 corners.
  spec.loop = generateCombLoop(40, 20, 2.5, 3, 150 + 16 * (2 - kPi / 2) * 1.0);
  spec.corner_radius_m = 1.0;
  return spec;
}

Eigen::Vector2d xy(const RobotMotion& m, double t) {
  return m.worldFromBase(t).translation.head<2>();
}

void checkLimits(const MotionSpec& spec) {
  const RobotMotion motion(spec, 5);
  const double h = 0.01;
  double max_speed = 0, max_tangential = 0, max_total = 0, max_lateral = 0;
  for (double t = h; t + h < motion.duration(); t += h) {
    const Eigen::Vector2d a = xy(motion, t - h), b = xy(motion, t), c = xy(motion, t + h);
    const double v = (c - a).norm() / (2 * h);
    max_speed = std::max(max_speed, (c - b).norm() / h);
    const Eigen::Vector2d acceleration = (c - 2 * b + a) / (h * h);
    max_total = std::max(max_total, acceleration.norm());
    const double dv = (motion.speedAt(t + h) - motion.speedAt(t - h)) / (2 * h);
    max_tangential = std::max(max_tangential, std::abs(dv));
    max_lateral =
        std::max(max_lateral, v * v * std::abs(motion.loopCurvature(motion.arcLengthAt(t))));
  }
  EXPECT_LE(max_speed, spec.max_speed_mps * 1.001);
  EXPECT_GT(max_speed, 0.7 * spec.max_speed_mps);  // it does get going
  EXPECT_LE(max_tangential, spec.max_acceleration_mps2 * 1.02);
  EXPECT_LE(max_lateral, spec.max_lateral_acceleration_mps2 * 1.05);
  // Total acceleration from positions alone (second differences): bounded.
  EXPECT_LE(max_total,
            1.1 * std::hypot(spec.max_acceleration_mps2, spec.max_lateral_acceleration_mps2));
}

TEST(Motion, RespectsSpeedAndAccelerationLimits) {
  checkLimits(rectangleSpec());
  MotionSpec fast = rectangleSpec();
  fast.max_speed_mps = 0.6;
  fast.max_acceleration_mps2 = 0.5;
  fast.max_lateral_acceleration_mps2 = 0.2;
  fast.corner_radius_m = 0.5;
  checkLimits(fast);
}

TEST(Motion, AccelerationIsContinuous) {
  // The speed profile is smoothed: between two 10 ms steps the tangential
  // acceleration changes by a small amount (no bang-bang jumps).
  const RobotMotion motion(rectangleSpec(), 5);
  const double h = 0.01;
  double previous = 0, max_jump = 0;
  for (double t = h; t + h < motion.duration(); t += h) {
    const double a = (motion.speedAt(t + h) - motion.speedAt(t - h)) / (2 * h);
    if (t > 2 * h) max_jump = std::max(max_jump, std::abs(a - previous));
    previous = a;
  }
  EXPECT_LT(max_jump, 0.03);  // m/s^2 per 10 ms, i.e. jerk below 3 m/s^3
}

TEST(Motion, StartsAndEndsAtRestAndTheLoopCloses) {
  const RobotMotion motion(rectangleSpec(), 5);
  EXPECT_EQ(motion.speedAt(0), 0);
  EXPECT_EQ(motion.speedAt(motion.duration()), 0);
  const Rigid3d start = motion.worldFromBase(0), end = motion.worldFromBase(motion.duration());
  EXPECT_LT((start.translation - end.translation).norm(), 1e-6);
  EXPECT_LT(rotationAngleBetween(start.rotation, end.rotation), 1e-6);
  EXPECT_NEAR(motion.arcLengthAt(motion.duration()), motion.pathLength(), 1e-9);
  EXPECT_NEAR(motion.pathLength(), 2 * motion.loopLength(), 1e-9);
  // The loop itself is continuous where it wraps.
  EXPECT_LT((motion.loopPoint(motion.loopLength() - 1e-9) - motion.loopPoint(0)).norm(), 1e-6);
  // Waiting at both ends.
  EXPECT_LT((motion.worldFromBase(0.9).translation - start.translation).norm(), 1e-12);
}

TEST(Motion, PathIsContinuousAndYawFollowsIt) {
  const RobotMotion motion(rectangleSpec(), 5);
  // Position and heading continuous along the loop (segments join).
  for (double s = 0; s < motion.loopLength(); s += 0.01) {
    EXPECT_LT((motion.loopPoint(s + 0.01) - motion.loopPoint(s)).norm(), 0.0101) << s;
    const double dh = std::remainder(motion.loopHeading(s + 0.01) - motion.loopHeading(s), 2 * kPi);
    EXPECT_LT(std::abs(dh), 0.011) << s;  // curvature <= 1 / (1 m)
  }
  for (double t = 1.5; t < motion.duration() - 1.5; t += 0.1) {
    const Eigen::Vector2d velocity = xy(motion, t + 1e-3) - xy(motion, t - 1e-3);
    if (velocity.norm() < 1e-5) continue;
    const Eigen::Vector3d forward = motion.worldFromBase(t).rotation * Eigen::Vector3d::UnitX();
    const double angle =
        std::acos(std::clamp(forward.head<2>().normalized().dot(velocity.normalized()), -1.0, 1.0));
    EXPECT_LT(angle, 0.01) << "t = " << t;
  }
}

TEST(Motion, PathLengthAsConfigured) {
  const RobotMotion comb(combSpec(), 1);
  EXPECT_NEAR(comb.loopLength(), 150, 0.05 * 150);
  EXPECT_NEAR(comb.loopLength(), 150, 0.5);  // the corner correction is exact for 90 deg
  // A polygon loop is its length minus what the rounded corners cut.
  const RobotMotion rectangle(rectangleSpec(), 1);
  EXPECT_NEAR(rectangle.loopLength(), 24 - 4 * (2 - kPi / 2) * 1.0, 1e-6);
  // The comb stays inside the facility, at the margin.
  for (const Eigen::Vector2d& p : combSpec().loop) {
    EXPECT_GE(p.x(), 2.5 - 1e-9);
    EXPECT_LE(p.x(), 37.5 + 1e-9);
    EXPECT_GE(p.y(), 2.5 - 1e-9);
    EXPECT_LE(p.y(), 17.5 + 1e-9);
  }
  EXPECT_THROW(generateCombLoop(40, 20, 2.5, 1, 400), Error);  // too long for one notch
  EXPECT_THROW(generateCombLoop(40, 20, 2.5, 2, 50), Error);   // shorter than the rectangle
}

TEST(Motion, RollAndPitchSmallButPresent) {
  MotionSpec spec = rectangleSpec();
  const RobotMotion motion(spec, 3);
  double max_tilt = 0;
  for (double t = 0; t < motion.duration(); t += 0.05) {
    const Eigen::Vector3d up = motion.worldFromBase(t).rotation * Eigen::Vector3d::UnitZ();
    max_tilt = std::max(max_tilt, std::acos(std::clamp(up.z(), -1.0, 1.0)));
    EXPECT_LT(std::abs(motion.worldFromBase(t).translation.z()), 0.02);
  }
  EXPECT_LT(max_tilt, 1.5 * kPi / 180);
  EXPECT_GT(max_tilt, 0.05 * kPi / 180);
  spec.floor_amplitude_m = 0;
  const RobotMotion flat(spec, 3);
  for (double t = 0; t < flat.duration(); t += 0.5) {
    const Eigen::Vector3d up = flat.worldFromBase(t).rotation * Eigen::Vector3d::UnitZ();
    EXPECT_NEAR(up.z(), 1.0, 1e-12);
  }
}

TEST(Motion, DistanceToLoop) {
  const RobotMotion motion(rectangleSpec(), 1);
  EXPECT_NEAR(motion.distanceToLoop({6, 2}), 0, 1e-3);
  EXPECT_NEAR(motion.distanceToLoop({6, 4}), 2, 1e-3);
  EXPECT_NEAR(motion.distanceToLoop({6, 0.5}), 1.5, 1e-3);
}

TEST(Motion, DeterministicFloorAndInvalidSpecs) {
  const RobotMotion a(rectangleSpec(), 9), b(rectangleSpec(), 9), c(rectangleSpec(), 10);
  EXPECT_EQ(a.floorHeight(3.3, 4.4), b.floorHeight(3.3, 4.4));
  EXPECT_NE(a.floorHeight(3.3, 4.4), c.floorHeight(3.3, 4.4));
  MotionSpec bad = rectangleSpec();
  bad.max_speed_mps = -1;
  EXPECT_NE(bad.check().find("'max_speed_mps'"), std::string::npos);
  EXPECT_THROW(RobotMotion(bad, 1), Error);
  bad = rectangleSpec();
  bad.loop.resize(2);
  EXPECT_NE(bad.check().find("'loop'"), std::string::npos);
  bad = rectangleSpec();
  bad.loop = {{0, 0}, {4, 0}, {8, 0}, {4, 0.0}};
  EXPECT_THROW(RobotMotion(bad, 1), Error);  // turns back on itself
}

}  // namespace
}  // namespace lookboth::sim
