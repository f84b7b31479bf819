// The odometry end to end on rendered scenarios (generated here, a few
// seconds each): a loop found when a place is revisited in the opposite
// direction, and what it brings.
#include "lookboth/vo/odometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/sim/simulate.h"
#include "lookboth/vo/run.h"

namespace lookboth::vo {
namespace {

namespace fs = std::filesystem;

fs::path testDirectory(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("lookboth_vo_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

fs::path simulateScenario(const std::string& scenario, const fs::path& dir, double seconds) {
  sim::SimulateOptions options;
  options.scenario = scenario;
  options.out = dir / "data.rawlog";
  options.max_duration_s = seconds;
  options.overwrite = true;
  sim::simulate(options, ProgressReporter());
  return options.out;
}

/// Writes a scenario: `small`'s room, loop and cameras' calibration, with a
/// single environment camera that the robot barely passes (the test needs
/// the fisheye frames; environment frames would only cost rendering time).
fs::path writeScenario(const fs::path& dir, const std::string& name, const std::string& loop,
                       double wait_s) {
  const fs::path path = dir / (name + ".yaml");
  std::ofstream(path) << "name: " << name << R"(
description: odometry test
seed: 7
world: {length_m: 12, width_m: 8, ceiling_min_m: 3.0, ceiling_max_m: 4.0, slab_size_m: 4, beams: 3, ducts: 1, light_panels: 10, cable_trays: 1, vents: 6}
robot:
  loop: )" << loop << R"(
  corner_radius_m: 0.5
  max_speed_mps: 1.0
  max_acceleration_mps2: 0.5
  laps: 1
  wait_s: )" << wait_s << R"(
  fisheye: {calibration: fisheye_640x360_calib_results.txt, rate_hz: 10}
marker: {dictionary: DICT_4X4_50, id: 7, size_m: 0.2}
cameras: {count: 1, calibration: ceiling_camera_640x360_ros.yaml, rate_hz: 10, store_radius_m: 0.3, lateral_offset_max_m: 0.1}
render: {fisheye_supersampling: 1, env_supersampling: 1}
)";
  return path;
}

Trajectory groundTruth(const fs::path& dataset) {
  auto reader = DatasetReader::open(dataset);
  Trajectory truth;
  while (auto record = reader->next()) {
    if (const auto* p = std::get_if<PoseSample>(&*record)) {
      if (p->label == "ground_truth" && (truth.empty() || p->t > truth.endTime()))
        truth.append(p->t, p->world_from_body);
    }
  }
  return truth;
}

// An aisle driven out along one lane and back along the other, 1.2 m apart:
// the second pass sees the ceiling rotated by 180 deg about the optical axis.
TEST(OdometryTest, LoopClosedWhenRevisitedInTheOppositeDirection) {
  const fs::path dir = testDirectory("revisit");
  const fs::path scenario =
      writeScenario(dir, "aisle", "[[2, 3], [9, 3], [9, 4.2], [2, 4.2]]", 0.5);
  const fs::path dataset = simulateScenario(scenario.string(), dir, 0);
  const Trajectory truth = groundTruth(dataset);
  OdometryRunOptions options;
  options.dataset = dataset;
  const OdometryRunSummary with_loops = runOdometry(options, ProgressReporter());
  const OdometryStatistics& s = with_loops.result.statistics;
  ASSERT_GE(s.loop_closures, 1);
  // The loop joins the two lanes: keyframes close in space, opposite in heading.
  bool opposite = false;
  for (const auto& [t_current, t_old] : s.loops) {
    const auto a = truth.interpolate(t_current, 0);
    const auto b = truth.interpolate(t_old, 0);
    ASSERT_TRUE(a.ok() && b.ok());
    const double distance = (a.world_from_body.translation - b.world_from_body.translation).norm();
    const double turn =
        rotationAngleBetween(a.world_from_body.rotation, b.world_from_body.rotation);
    EXPECT_LT(distance, 2.5);
    opposite = opposite || turn > 2.5;  // rad: ~180 deg about the vertical
  }
  EXPECT_TRUE(opposite);
  ASSERT_TRUE(with_loops.ate);
  options.odometry.loop_closure = false;
  const OdometryRunSummary without = runOdometry(options, ProgressReporter());
  ASSERT_TRUE(without.ate);
  EXPECT_EQ(without.result.statistics.loop_closures, 0);
  EXPECT_LT(with_loops.ate->rmse, without.ate->rmse);
}

}  // namespace
}  // namespace lookboth::vo
