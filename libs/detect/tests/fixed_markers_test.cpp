// Markers fixed in the facility (detect.markers.fixed_marker_sizes_m):
// found in the frames spread over each camera's recording, at their true
// pose, written beside the robot's marker without changing its detections.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "lookboth/core/error.h"
#include "lookboth/core/paths.h"
#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/detect/detect_dataset.h"
#include "lookboth/sim/simulate.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

// `small`'s first 3 s, rendered with a 0.3 m marker (id 23) on the floor
// 3.6 m from cam03, which sees the robot from the start.
class FixedMarkersTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / "lookboth_fixed_markers_test";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ifstream in(shareDirectory() / "scenarios" / "small.yaml");
    std::stringstream text;
    text << in.rdbuf();
    std::ofstream(dir_ / "floor_marker.yaml")
        << text.str() << "\nfloor_markers:\n  - {id: 23, position_m: [" << kMarker.x() << ", "
        << kMarker.y() << ", 0], yaw_deg: 90, size_m: 0.3}\n";
    sim::SimulateOptions options;
    options.scenario = (dir_ / "floor_marker.yaml").string();
    options.out = dir_ / "drive.rawlog";
    options.max_duration_s = 3.0;
    options.threads = 2;
    sim::simulate(options, ProgressReporter());
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::vector<MarkerObservation> detect(const DetectConfig& config) {
    DetectOptions options;
    options.dataset = dir_ / "drive.rawlog";
    options.blobs = false;
    options.config = config;
    std::vector<MarkerObservation> markers;
    for (const Record& r : runDetection(options, ProgressReporter(), nullptr)) {
      if (const auto* m = std::get_if<MarkerObservation>(&r)) markers.push_back(*m);
    }
    return markers;
  }

  static inline const Eigen::Vector3d kMarker{2.895, 2.383, 0.0};
  static fs::path dir_;
};
fs::path FixedMarkersTest::dir_;

TEST_F(FixedMarkersTest, FoundAtTheirPoseBesideTheRobotsMarker) {
  DetectConfig config = defaultDetectConfig();
  const std::vector<MarkerObservation> plain = detect(config);
  config.markers.fixed_marker_sizes_m = {{"23", 0.3}};
  config.markers.fixed_marker_frames = 6;
  const std::vector<MarkerObservation> with_fixed = detect(config);
  const Manifest manifest = DatasetReader::open(dir_ / "drive.rawlog")->manifest();
  const Rigid3d world_from_cam03 = manifest.ground_truth.world_from_camera.at("cam03");
  std::vector<MarkerObservation> robot, fixed;
  for (const MarkerObservation& m : with_fixed) (m.marker_id == 23 ? fixed : robot).push_back(m);
  ASSERT_EQ(robot.size(), plain.size());  // the robot's marker as without them
  for (std::size_t i = 0; i < robot.size(); ++i) {
    EXPECT_EQ(robot[i].t, plain[i].t);
    EXPECT_EQ(robot[i].camera_from_marker.translation, plain[i].camera_from_marker.translation);
  }
  int cam03 = 0;
  for (const MarkerObservation& m : fixed) {
    if (m.camera != "cam03") continue;
    ++cam03;
    const Eigen::Vector3d p = world_from_cam03 * m.camera_from_marker.translation;
    EXPECT_LT((p - kMarker).norm(), 0.01) << "at " << m.t;
  }
  EXPECT_EQ(cam03, 6);  // one per frame searched
}

TEST_F(FixedMarkersTest, TheRobotsIdIsNotAFixedMarker) {
  DetectConfig config = defaultDetectConfig();
  const int robot = DatasetReader::open(dir_ / "drive.rawlog")->manifest().marker.id;
  config.markers.fixed_marker_sizes_m = {{std::to_string(robot), 0.3}};
  try {
    detect(config);
    FAIL() << "the robot's marker accepted as a fixed one";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("is the robot's"), std::string::npos) << e.what();
  }
  MarkerDetectorOptions options;
  options.fixed_marker_sizes_m = {{"twenty", 0.3}};
  EXPECT_NE(options.check().find("'twenty' is not a marker id"), std::string::npos);
  options.fixed_marker_sizes_m = {{"20", -1}};
  EXPECT_NE(options.check().find("side"), std::string::npos);
  options.fixed_marker_sizes_m = {{"20", 0.3}, {"020", 0.3}};
  EXPECT_NE(options.check().find("listed twice"), std::string::npos);
  // The robot's id written another way is still the robot's.
  config.markers.fixed_marker_sizes_m = {{"0" + std::to_string(robot), 0.3}};
  EXPECT_THROW(detect(config), Error);
}

}  // namespace
}  // namespace lookboth
