// Scenario files: the built-ins load and validate, errors name the field and
// the line, camera placement is deterministic, under the ceiling, looking
// down, and along the robot's path.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "lookboth/core/error.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/world.h"

namespace lookboth::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;

const char* kMinimal = R"(name: tiny
seed: 3
world: {length_m: 12, width_m: 8}
robot:
  loop: [[2, 2], [10, 2], [10, 6], [2, 6]]
  fisheye: {calibration: fisheye_640x360_calib_results.txt, rate_hz: 10}
cameras:
  count: 4
  calibration: ceiling_camera_640x360_ros.yaml
)";

Scenario parse(const std::string& yaml) { return scenarioFromYaml(yaml, "test.yaml", ""); }

/// The message of the Error that parsing throws ("" when it does not throw).
std::string parseError(const std::string& yaml) {
  try {
    parse(yaml);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

TEST(Scenario, BuiltinsLoadAndValidate) {
  const std::vector<std::string> names = builtinScenarioNames();
  for (const char* expected : {"faults", "paper", "revisit", "small"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
  for (const std::string& name : names) {
    SCOPED_TRACE(name);
    const Scenario scenario = loadScenario(name);
    EXPECT_EQ(scenario.name, name);
    EXPECT_EQ(scenario.check(), "");
    EXPECT_TRUE(fs::exists(scenario.robot.fisheye.calibration));
    EXPECT_TRUE(fs::exists(scenario.cameras.calibration));
    EXPECT_LE(scenario.robot.motion.max_speed_mps, 1.0);
    // A realistic mount: not identity.
    const Rigid3d mount = scenario.robot.marker_mount.fisheyeFromMarker();
    EXPECT_GT(mount.translation.norm(), 0.05);
    // Loaded by path, too.
    EXPECT_EQ(loadScenario((builtinScenarioDirectory() / (name + ".yaml")).string()).name, name);
  }
  const Scenario paper = loadScenario("paper");
  EXPECT_EQ(paper.cameras.count, 43);
  EXPECT_NEAR(paper.world.length_m * paper.world.width_m, 800, 100);
  EXPECT_NEAR(RobotMotion(paper.robot.motion, 1).loopLength(), 150, 7.5);
  EXPECT_EQ(paper.cameras.rate_hz, 30);
  EXPECT_EQ(paper.robot.fisheye.rate_hz, 30);
  const Scenario faults = loadScenario("faults");
  EXPECT_TRUE(faults.faults.any());
  EXPECT_TRUE(faults.faults.unvisited_camera);
  EXPECT_FALSE(loadScenario("small").faults.any());
}

TEST(Scenario, UnknownNameListsTheBuiltins) {
  try {
    loadScenario("no_such_scenario");
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("unknown scenario 'no_such_scenario'"), std::string::npos) << message;
    EXPECT_NE(message.find("faults, paper, revisit, small"), std::string::npos) << message;
  }
  EXPECT_THROW(loadScenario("/nonexistent/x.yaml"), Error);
}

TEST(Scenario, MinimalFileGetsDefaults) {
  const Scenario s = parse(kMinimal);
  EXPECT_EQ(s.name, "tiny");
  EXPECT_EQ(s.seed, 3u);
  EXPECT_EQ(s.cameras.count, 4);
  EXPECT_EQ(s.robot.motion.loop.size(), 4u);
  EXPECT_EQ(s.robot.fisheye.label, "fisheye");
  EXPECT_EQ(s.marker.dictionary, "DICT_4X4_50");
  EXPECT_EQ(s.lines.at("cameras.count"), 8);
  EXPECT_EQ(s.lines.at("robot.loop"), 5);
}

// A full recording: every frame of every camera, as real cameras record.
TEST(Scenario, StoreRadiusAllKeepsEveryFrame) {
  const Scenario s =
      parse(replace(kMinimal, "  count: 4\n", "  count: 4\n  store_radius_m: all\n"));
  EXPECT_TRUE(std::isinf(s.cameras.store_radius_m));
  EXPECT_EQ(s.check(), "");
  EXPECT_NE(parseError(replace(kMinimal, "  count: 4\n", "  count: 4\n  store_radius_m: most\n")),
            "");
}

TEST(Scenario, CameraVideoIsReadAndChecked) {
  EXPECT_FALSE(parse(kMinimal).cameras.video.has_value());
  const Scenario s = parse(replace(kMinimal, "  count: 4\n",
                                   "  count: 4\n  video: {crf: 28, key_frame_interval_s: 2}\n"));
  ASSERT_TRUE(s.cameras.video.has_value());
  EXPECT_EQ(s.cameras.video->codec, "libx264");
  EXPECT_EQ(s.cameras.video->crf, 28);
  EXPECT_EQ(s.cameras.video->preset, "veryfast");
  EXPECT_EQ(s.cameras.video->key_frame_interval_s, 2);
  EXPECT_EQ(s.check(), "");
  EXPECT_NE(parseError(replace(kMinimal, "  count: 4\n", "  count: 4\n  video: {crf: 60}\n"))
                .find("'cameras.video.crf': must be in [0, 51]"),
            std::string::npos);
  EXPECT_NE(parseError(replace(kMinimal, "  count: 4\n", "  count: 4\n  video: {crfs: 20}\n"))
                .find("'cameras.video.crfs': unknown key"),
            std::string::npos);
}

// A later drive of the same facility: another noise seed, moved cameras.
TEST(Scenario, LaterDriveReadsItsSeedAndMoves) {
  const Scenario s =
      parse(std::string(kMinimal) +
            "later_drive:\n  noise_seed: 11\n  moved:\n"
            "    - {camera: cam01, translate_m: [0.03, 0, 0], rotate_deg: [0, 0, 1]}\n");
  EXPECT_TRUE(s.later_drive.active());
  EXPECT_EQ(s.later_drive.noise_seed, 11u);
  ASSERT_EQ(s.later_drive.moved.size(), 1u);
  EXPECT_EQ(s.later_drive.moved[0].camera, "cam01");
  EXPECT_EQ(s.later_drive.moved[0].translate_m, Eigen::Vector3d(0.03, 0, 0));
  EXPECT_EQ(s.later_drive.moved[0].rotate_deg, Eigen::Vector3d(0, 0, 1));
  EXPECT_TRUE(s.later_drive.moved[0].replaced_by.empty());
  EXPECT_EQ(parse(std::string(kMinimal) +
                  "later_drive:\n  moved:\n    - {camera: cam01, replaced_by: cam01b}\n")
                .later_drive.moved[0]
                .replaced_by,
            "cam01b");
  EXPECT_NE(parseError(std::string(kMinimal) +
                       "later_drive:\n  moved:\n    - {camera: cam01, replaced_by: '#cam'}\n")
                .find("later_drive.moved[0].replaced_by"),
            std::string::npos);
  EXPECT_FALSE(parse(kMinimal).later_drive.active());
  EXPECT_NE(parseError(std::string(kMinimal) + "later_drive:\n  noise_seed: 0\n")
                .find("later_drive.noise_seed"),
            std::string::npos);
  EXPECT_NE(parseError(std::string(kMinimal) +
                       "later_drive:\n  moved:\n    - {camera: cam01, shift: 1}\n")
                .find("later_drive.moved[0].shift"),
            std::string::npos);
}

// Markers fixed on the floor: read with their defaults; an id taken by the
// robot's marker or another floor marker, or outside the dictionary, is named.
TEST(Scenario, FloorMarkersAreReadAndChecked) {
  const std::string list = "floor_markers:\n  - {id: 20, position_m: [1, 2, 0], yaw_deg: 30}\n";
  const Scenario s = parse(std::string(kMinimal) + list);
  ASSERT_EQ(s.floor_markers.size(), 1u);
  EXPECT_EQ(s.floor_markers[0].id, 20);
  EXPECT_EQ(s.floor_markers[0].position_m, Eigen::Vector3d(1, 2, 0));
  EXPECT_EQ(s.floor_markers[0].yaw_deg, 30);
  EXPECT_EQ(s.floor_markers[0].size_m, 0.3);
  EXPECT_TRUE(parse(kMinimal).floor_markers.empty());
  const std::string robot_id = std::to_string(s.marker.id);
  EXPECT_NE(parseError(std::string(kMinimal) + "floor_markers:\n  - {id: " + robot_id +
                       ", position_m: [1, 2, 0]}\n")
                .find("floor_markers[0].id"),
            std::string::npos);
  EXPECT_NE(parseError(std::string(kMinimal) + list + "  - {id: 20, position_m: [3, 2, 0]}\n")
                .find("floor_markers[1].id"),
            std::string::npos);
  EXPECT_NE(
      parseError(std::string(kMinimal) + "floor_markers:\n  - {id: 5000, position_m: [1, 2, 0]}\n")
          .find("floor_markers[0].id"),
      std::string::npos);
  EXPECT_NE(parseError(std::string(kMinimal) + "floor_markers:\n  - {id: 21}\n").find("position_m"),
            std::string::npos);
}

TEST(Scenario, ErrorsNameTheFieldAndTheLine) {
  struct Case {
    std::string yaml, expected;
  };
  const std::vector<Case> cases = {
      // Unknown key (a typo), with the line.
      {replace(kMinimal, "  count: 4\n", "  count: 4\n  rate_hzz: 3\n"),
       "test.yaml:9: 'cameras.rate_hzz': unknown key"},
      // Not a number.
      {replace(kMinimal, "count: 4", "count: four"),
       "test.yaml:8: 'cameras.count': 'four' is not an integer"},
      // Out of range, found after parsing, still with its line.
      {replace(kMinimal, "rate_hz: 10}", "rate_hz: 10}\n  max_speed_mps: 7"),
       "test.yaml:7: 'robot.max_speed_mps': must be in (0, 2], got 7"},
      {replace(kMinimal, "count: 4", "count: 0"),
       "test.yaml:8: 'cameras.count': must be in [1, 1000]"},
      // A point outside the facility.
      {replace(kMinimal, "[10, 6]", "[13, 6]"), "test.yaml:5: 'robot.loop': point 2 (13, 6)"},
      // Missing required parts.
      {replace(kMinimal, "  calibration: ceiling_camera_640x360_ros.yaml\n", ""),
       "'cameras.calibration': missing"},
      {replace(kMinimal, "  loop: [[2, 2], [10, 2], [10, 6], [2, 6]]\n", ""),
       "'robot.loop': missing"},
      // A calibration that does not exist.
      {replace(kMinimal, "fisheye_640x360_calib_results.txt", "nope.txt"),
       "test.yaml:6: 'robot.fisheye.calibration': calibration file not found"},
      // Bad YAML.
      {replace(kMinimal, "count: 4", "count: [4"), "test.yaml:"},
      // Wrong shapes.
      {replace(kMinimal, "[10, 2],", "[10, 2, 3],"), "'robot.loop[1]': expected 2 numbers, got 3"},
      {replace(kMinimal, "seed: 3", "seed: -3"), "test.yaml:2: 'seed': must be in"},
      // Faults.
      {std::string(kMinimal) + "faults: {drop_probability: 1.5}\n",
       "test.yaml:10: 'faults.drop_probability': must be in [0, 0.9]"},
      {std::string(kMinimal) + "faults: {clock_jump: {node: cam01}}\n",
       "'faults.clock_jump.offset_ms': missing"},
      {std::string(kMinimal) + "faults:\n  motion_blur: [{start_s: 5, end_s: 2, blur_px: 3}]\n",
       "'faults.motion_blur[0]': needs 0 <= start_s < end_s"},
      {std::string(kMinimal) + "faults: {low_texture_region: [1, 2, 3]}\n",
       "'faults.low_texture_region': expected 4 numbers"},
      // Checks of other modules keep the scenario's field names.
      {replace(kMinimal, "world: {length_m: 12, width_m: 8}",
               "world: {length_m: 12, width_m: 8, ceiling_min_m: 5, ceiling_max_m: 4}"),
       "test.yaml:3: 'world.ceiling"},
      {std::string(kMinimal) + "marker: {id: 99}\n",
       "test.yaml:10: 'marker.id': 99 is not in DICT_4X4_50"},
      {replace(kMinimal, "  count: 4\n", "  count: 4\n  lateral_offset_max_m: 3\n"),
       "'cameras.lateral_offset_max_m': must be in [0, 2.25"},
  };
  for (const Case& c : cases) {
    const std::string message = parseError(c.yaml);
    EXPECT_NE(message.find(c.expected), std::string::npos)
        << "expected '" << c.expected << "' in '" << message << "' for:\n"
        << c.yaml;
  }
  EXPECT_EQ(parseError(kMinimal), "");
}

TEST(Scenario, CalibrationsRelativeToTheScenarioFile) {
  const fs::path dir = fs::temp_directory_path() / "lookboth_scenario_relative";
  fs::remove_all(dir);
  fs::create_directories(dir / "cams");
  fs::copy_file(fs::path(LOOKBOTH_SHARE_DIR) / "cameras" / "ceiling_camera_640x360_ros.yaml",
                dir / "cams" / "mine.yaml");
  {
    std::ofstream out(dir / "s.yaml");
    out << replace(kMinimal, "calibration: ceiling_camera_640x360_ros.yaml",
                   "calibration: cams/mine.yaml");
  }
  const Scenario s = loadScenario((dir / "s.yaml").string());
  EXPECT_EQ(s.cameras.calibration, fs::absolute(dir / "cams" / "mine.yaml").lexically_normal());
  fs::remove_all(dir);
}

struct Placed {
  Scenario scenario;
  std::unique_ptr<World> world;
  std::unique_ptr<RobotMotion> motion;
  std::vector<EnvCameraPlacement> cameras;
};

Placed place(const std::string& name, std::uint32_t seed) {
  Placed p;
  p.scenario = loadScenario(name);
  p.world = std::make_unique<World>(p.scenario.world, streamSeed(seed, "world"));
  p.motion = std::make_unique<RobotMotion>(p.scenario.robot.motion, streamSeed(seed, "floor"));
  const World& world = *p.world;
  p.cameras = placeEnvCameras(
      p.scenario, *p.motion, [&world](double x, double y) { return world.ceilingHeightAt(x, y); },
      seed);
  return p;
}

TEST(Scenario, PlacementIsDeterministicForASeed) {
  const Placed a = place("small", 7), b = place("small", 7), c = place("small", 8);
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  bool all_same_as_c = a.cameras.size() == c.cameras.size();
  for (size_t i = 0; i < a.cameras.size(); ++i) {
    EXPECT_EQ(a.cameras[i].label, b.cameras[i].label);
    EXPECT_EQ(a.cameras[i].world_from_camera.translation,
              b.cameras[i].world_from_camera.translation);
    EXPECT_EQ(a.cameras[i].world_from_camera.rotation.coeffs(),
              b.cameras[i].world_from_camera.rotation.coeffs());
    if (all_same_as_c) {
      all_same_as_c =
          a.cameras[i].world_from_camera.translation == c.cameras[i].world_from_camera.translation;
    }
  }
  EXPECT_FALSE(all_same_as_c);
  EXPECT_NE(streamSeed(1, "a"), streamSeed(1, "b"));
  EXPECT_NE(streamSeed(1, "a"), streamSeed(2, "a"));
  EXPECT_NE(itemSeed(1, "a", 0), itemSeed(1, "a", 1));
}

TEST(Scenario, CamerasAlongThePathUnderTheCeilingLookingDown) {
  for (const std::string name : {"small", "paper", "revisit", "faults"}) {
    for (const std::uint32_t seed : {1u, 2u, 77u}) {
      SCOPED_TRACE(name + " seed " + std::to_string(seed));
      const Placed p = place(name, seed);
      const EnvCamerasSpec& spec = p.scenario.cameras;
      ASSERT_EQ(static_cast<int>(p.cameras.size()),
                spec.count + (p.scenario.faults.unvisited_camera ? 1 : 0));
      std::set<std::string> labels;
      double min_yaw = 10, max_yaw = -10;
      for (const EnvCameraPlacement& c : p.cameras) {
        SCOPED_TRACE(c.label);
        EXPECT_TRUE(labels.insert(c.label).second);
        const Eigen::Vector3d centre = c.world_from_camera.translation;
        // Inside the facility, just under the ceiling.
        EXPECT_GT(centre.x(), 0);
        EXPECT_LT(centre.x(), p.scenario.world.length_m);
        EXPECT_GT(centre.y(), 0);
        EXPECT_LT(centre.y(), p.scenario.world.width_m);
        const double ceiling = p.world->ceilingHeightAt(centre.x(), centre.y());
        EXPECT_NEAR(centre.z(), ceiling - spec.mount_drop_m, 1e-9);
        EXPECT_LT(centre.z() + spec.housing_height_m, ceiling);
        EXPECT_GE(ceiling, p.scenario.world.ceiling_min_m - 1e-9);
        EXPECT_LE(ceiling, p.scenario.world.ceiling_max_m + 1e-9);
        // Looking down within the configured tilt.
        const Eigen::Vector3d axis = c.world_from_camera.rotation * Eigen::Vector3d::UnitZ();
        const double tilt = std::acos(std::clamp(-axis.z(), -1.0, 1.0));
        EXPECT_LE(tilt, spec.tilt_max_deg * kPi / 180 + 1e-9);
        const Eigen::Vector3d x = c.world_from_camera.rotation * Eigen::Vector3d::UnitX();
        min_yaw = std::min(min_yaw, std::atan2(x.y(), x.x()));
        max_yaw = std::max(max_yaw, std::atan2(x.y(), x.x()));
        // The robot passes within store_radius_m of the point under it
        // (except the camera of the never-visited fault).
        const double distance = p.motion->distanceToLoop(centre.head<2>());
        if (c.never_visited) {
          EXPECT_GT(distance, spec.store_radius_m);
        } else {
          EXPECT_LE(distance, spec.lateral_offset_max_m + 1e-6);
          EXPECT_LT(distance, spec.store_radius_m);
        }
      }
      if (p.cameras.size() >= 6) {
        EXPECT_GT(max_yaw - min_yaw, 1.0);  // any yaw
      }
      // Spread along the loop: no two cameras at one place.
      for (size_t i = 0; i < p.cameras.size(); ++i) {
        for (size_t j = i + 1; j < p.cameras.size(); ++j) {
          EXPECT_GT((p.cameras[i].world_from_camera.translation -
                     p.cameras[j].world_from_camera.translation)
                        .head<2>()
                        .norm(),
                    1.0);
        }
      }
    }
  }
}

TEST(Scenario, UnvisitedCameraNeedsRoom) {
  Scenario s = parse(std::string(kMinimal) + "faults: {unvisited_camera: true}\n");
  const World world(s.world, 1);
  const RobotMotion motion(s.robot.motion, 1);
  // The 12 m x 8 m room has no place 2.5 m + 0.5 m from the rectangle loop.
  s.cameras.store_radius_m = 2.5;
  EXPECT_THROW(placeEnvCameras(
                   s, motion, [&](double x, double y) { return world.ceilingHeightAt(x, y); }, 1),
               Error);
}

TEST(Scenario, BaseFromFisheyeLooksUpAndMountIsNotIdentity) {
  const Scenario s = loadScenario("small");
  const Rigid3d base_from_fisheye = baseFromFisheye(s.robot.fisheye);
  EXPECT_NEAR((base_from_fisheye.rotation * Eigen::Vector3d::UnitZ()).z(), 1.0, 1e-12);
  // The image's "down" is the robot's front.
  EXPECT_NEAR((base_from_fisheye.rotation * Eigen::Vector3d::UnitY()).x(), 1.0, 1e-12);
  EXPECT_NEAR(base_from_fisheye.translation.z(), 0.35, 1e-12);
  const Rigid3d mount = s.robot.marker_mount.fisheyeFromMarker();
  // 15 cm behind the fisheye (fisheye -y is the robot's back), 5 cm lower, facing up.
  EXPECT_NEAR(mount.translation.y(), -0.15, 1e-12);
  EXPECT_NEAR(mount.translation.z(), -0.05, 1e-12);
  EXPECT_GT((mount.rotation * Eigen::Vector3d::UnitZ()).z(), 0.999);
  const Eigen::Vector3d marker_in_base = base_from_fisheye * mount.translation;
  EXPECT_NEAR(marker_in_base.x(), 0.10 - 0.15, 1e-12);
  EXPECT_NEAR(marker_in_base.z(), 0.30, 1e-12);
}

}  // namespace
}  // namespace lookboth::sim
