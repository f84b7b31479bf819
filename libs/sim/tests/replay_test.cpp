// Replays of recorded drives: the path as driven, an error-free estimate
// recovered exactly, a known error carried over as it was, an unscaled
// estimate kept unscaled, and a dataset simulated from a replay scenario.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

#include "lookboth/core/error.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/geometry/tum.h"
#include "lookboth/sim/replay.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/simulate.h"

namespace lookboth::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
constexpr TimeNs kStart = 1'403'636'580'000'000'000;  // a recording's own clock

/// A body going round an ellipse (8 m x 5 m) in 40 s at 20 Hz, bobbing up
/// and down and tilted like a hand-held camera, with `drift` added.
Trajectory ellipse(const std::function<Rigid3d(double t, const Rigid3d&)>& drift = {}) {
  Trajectory trajectory;
  for (int i = 0; i <= 800; ++i) {
    const double t = 0.05 * i, a = 2 * kPi * t / 40;
    const Eigen::Vector3d p(4 * std::cos(a), 2.5 * std::sin(a), 1.2 + 0.3 * std::sin(3 * a));
    const Eigen::Quaterniond q(Eigen::AngleAxisd(a + 0.4, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(0.1 * std::sin(5 * a), Eigen::Vector3d::UnitX()));
    Rigid3d pose(q, p);
    if (drift) pose = drift(t, pose);
    trajectory.append(kStart + static_cast<TimeNs>(std::llround(t * 1e9)), pose);
  }
  return trajectory;
}

class ReplayTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_replay_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    writeTumFile(dir_ / "truth.tum", ellipse());
    spec_.path = dir_ / "truth.tum";
    spec_.odometry = dir_ / "estimate.tum";
  }
  void TearDown() override { fs::remove_all(dir_); }
  ReplaySpec spec_;
  fs::path dir_;
};

TEST_F(ReplayTest, DrivesThePathOnTheFloorHeadingAlongIt) {
  spec_.rotate_deg = 90;
  const ReplayedMotion motion(spec_, 20, 12);
  EXPECT_NEAR(motion.duration(), 40, 1e-9);
  // The ellipse turned by 90 deg (5 m along x, 8 m along y), centred.
  const Rigid3d start = motion.worldFromBase(0);
  EXPECT_NEAR(start.translation.x(), 10, 1e-9);
  EXPECT_NEAR(start.translation.y(), 6 + 4, 1e-9);
  EXPECT_EQ(start.translation.z(), 0);
  EXPECT_NEAR((start.rotation * Eigen::Vector3d::UnitZ()).z(), 1, 1e-12) << "level";
  // Half-way round, at the far end of the major axis, it heads along +x.
  const Rigid3d half = motion.worldFromBase(20);
  EXPECT_NEAR(half.translation.x(), 10, 1e-9);
  EXPECT_NEAR(half.translation.y(), 6 - 4, 1e-9);
  EXPECT_NEAR((half.rotation * Eigen::Vector3d::UnitX()).x(), 1, 1e-9);
  // Its length: Ramanujan's perimeter of the ellipse.
  const double a = 4, b = 2.5;
  const double perimeter = kPi * (3 * (a + b) - std::sqrt((3 * a + b) * (a + 3 * b)));
  EXPECT_NEAR(motion.loopLength(), perimeter, 0.01);
  EXPECT_NEAR(motion.arcLengthAt(20), 0.5 * perimeter, 0.02);
  EXPECT_NEAR(motion.distanceToLoop(Eigen::Vector2d(10, 6)), 2.5, 1e-3);
}

TEST_F(ReplayTest, APathLargerThanTheFacilityIsAnError) {
  spec_.scale = 3;  // 24 m x 15 m
  try {
    ReplayedMotion(spec_, 20, 12);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("'robot.replay': "), std::string::npos) << message;
    EXPECT_NE(message.find("24.0 m x 15.0 m"), std::string::npos) << message;
    EXPECT_NE(message.find("robot.replay.scale"), std::string::npos) << message;
  }
}

// The COLMAP way: an estimate without error replays as the path itself.
TEST_F(ReplayTest, AnErrorFreeEstimateIsThePathItself) {
  writeTumFile(spec_.odometry, ellipse());
  spec_.scale = 0.8;
  spec_.rotate_deg = 30;
  const ReplayedMotion motion(spec_, 20, 12);
  const auto odometry = replayedOdometry(motion);
  ASSERT_EQ(odometry.size(), 801u);
  for (const ReplayedPose& pose : odometry) {
    const Rigid3d truth = motion.worldFromBase(pose.t);
    EXPECT_LT((pose.world_from_base.translation - truth.translation).norm(), 1e-9) << pose.t;
    EXPECT_LT(pose.world_from_base.rotation.angularDistance(truth.rotation), 1e-9) << pose.t;
  }
}

// A drift of position (2 cm per second along the recording's y) and of
// heading (0.1 deg per second): carried over scaled and turned, whatever
// the body's own orientation in the recording.
TEST_F(ReplayTest, AKnownErrorIsCarriedOverAsItWas) {
  writeTumFile(spec_.odometry, ellipse([](double t, const Rigid3d& pose) {
                 const Eigen::Quaterniond yaw(
                     Eigen::AngleAxisd(0.1 * kPi / 180 * t, Eigen::Vector3d::UnitZ()));
                 return Rigid3d(yaw * pose.rotation,
                                pose.translation + Eigen::Vector3d(0, 0.02 * t, 0));
               }));
  spec_.scale = 0.5;
  spec_.rotate_deg = 90;
  const ReplayedMotion motion(spec_, 20, 12);
  for (const ReplayedPose& pose : replayedOdometry(motion)) {
    const Rigid3d truth = motion.worldFromBase(pose.t);
    // (0, 0.02 t) turned by 90 deg, scaled by 0.5: (-0.01 t, 0).
    const Eigen::Vector3d error = pose.world_from_base.translation - truth.translation;
    EXPECT_LT((error - Eigen::Vector3d(-0.01 * pose.t, 0, 0)).norm(), 1e-9) << pose.t;
    const Eigen::AngleAxisd rotation_error(pose.world_from_base.rotation *
                                           truth.rotation.conjugate());
    EXPECT_NEAR(rotation_error.angle(), 0.1 * kPi / 180 * pose.t, 1e-9) << pose.t;
    if (pose.t > 1) {
      EXPECT_NEAR(std::abs(rotation_error.axis().z()), 1, 1e-9);
    }
  }
}

// A monocular estimate: the same path at a third of its size. Replayed, the
// odometry has the estimate's scale (register finds it), and no error.
TEST_F(ReplayTest, AnUnscaledEstimateKeepsItsScale) {
  writeTumFile(spec_.odometry, ellipse([](double, const Rigid3d& pose) {
                 return Rigid3d(pose.rotation, pose.translation / 3);
               }));
  spec_.metric = false;
  const ReplayedMotion motion(spec_, 20, 12);
  for (const ReplayedPose& pose : replayedOdometry(motion)) {
    const Rigid3d truth = motion.worldFromBase(pose.t);
    EXPECT_LT((pose.world_from_base.translation - truth.translation / 3).norm(), 1e-6) << pose.t;
    EXPECT_LT(pose.world_from_base.rotation.angularDistance(truth.rotation), 1e-9) << pose.t;
  }
}

TEST_F(ReplayTest, ASimulatedDatasetUsesTheReplayedOdometry) {
  writeTumFile(spec_.odometry, ellipse([](double t, const Rigid3d& pose) {
                 return Rigid3d(pose.rotation, pose.translation + Eigen::Vector3d(0.01 * t, 0, 0));
               }));
  std::ifstream small(builtinScenarioDirectory() / "small.yaml");
  std::stringstream text;
  text << small.rdbuf();
  std::string yaml = text.str();
  const size_t loop = yaml.find("  loop:");
  const size_t end = yaml.find('\n', loop);
  ASSERT_NE(loop, std::string::npos);
  yaml.replace(loop, end - loop,
               "  replay: {path: truth.tum, odometry: estimate.tum, scale: 1.0, metric: true}");
  yaml.replace(yaml.find("length_m: 12"), 12, "length_m: 14");
  const fs::path scenario = dir_ / "scenario.yaml";
  std::ofstream(scenario) << yaml;

  SimulateOptions options;
  options.scenario = scenario.string();
  options.out = dir_ / "replay.rawlog";
  options.detections_only = true;
  const SimulateSummary summary = simulate(options, ProgressReporter());
  EXPECT_EQ(summary.cameras, 6);
  EXPECT_NEAR(summary.path_length_m,
              ReplayedMotion(loadScenario(scenario.string()).robot.replay, 14, 8).loopLength(),
              0.05);
  auto reader = DatasetReader::open(options.out);
  ASSERT_EQ(reader->manifest().trajectories.front().label, "odometry");
  EXPECT_NE(reader->manifest().trajectories.front().description.find("estimate.tum"),
            std::string::npos);
  std::vector<PoseSample> odometry, truth;
  while (auto record = reader->next()) {
    if (const auto* pose = std::get_if<PoseSample>(&*record)) {
      (pose->label == "odometry" ? odometry : truth).push_back(*pose);
    }
  }
  ASSERT_GT(odometry.size(), 700u);
  // 1 cm/s of drift along x, the last pose ~40 s in.
  const Trajectory ground_truth([&] {
    std::vector<StampedPose> samples;
    for (const PoseSample& p : truth) samples.push_back({p.t, p.world_from_body});
    return samples;
  }());
  const PoseSample& last = odometry[odometry.size() - 10];  // within the fisheye's frames
  const InterpolationResult at = ground_truth.interpolate(last.t, secondsToNs(1));
  ASSERT_TRUE(at.ok());
  const double elapsed = static_cast<double>(last.t - odometry.front().t) * 1e-9;
  EXPECT_NEAR((last.world_from_body.translation - at.world_from_body.translation).x(),
              0.01 * elapsed, 2e-3);
}

}  // namespace
}  // namespace lookboth::sim
