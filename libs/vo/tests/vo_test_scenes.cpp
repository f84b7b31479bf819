#include "vo_test_scenes.h"

#include <fstream>
#include <map>
#include <memory>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/sim/simulate.h"

namespace lookboth::vo::scenes {
namespace {

namespace fs = std::filesystem;

/// Folders made by this binary, removed at exit.
struct Folders {
  std::map<std::string, fs::path> scenes;  ///< Scene key -> dataset.
  std::vector<fs::path> made;
  ~Folders() {
    std::error_code ignored;
    for (const fs::path& dir : made) fs::remove_all(dir, ignored);
  }
};
Folders& folders() {
  static Folders f;
  return f;
}

/// `small`'s room and calibrations; a single environment camera that the
/// robot barely passes, at 0.5 Hz (the tests need the fisheye frames;
/// environment frames would only cost rendering time).
void writeScenario(const fs::path& path, const Scene& scene) {
  std::ofstream(path) << "name: " << scene.name << R"(
description: odometry test
seed: 7
world: {length_m: 12, width_m: 8, ceiling_min_m: 3.0, ceiling_max_m: 4.0, slab_size_m: 4, beams: 3, ducts: 1, light_panels: 10, cable_trays: 1, vents: 6}
robot:
  loop: )" << scene.loop
                      << R"(
  corner_radius_m: 0.5
  max_speed_mps: 1.0
  max_acceleration_mps2: 0.5
  laps: 1
  wait_s: )" << scene.wait_s
                      << R"(
  fisheye: {calibration: fisheye_640x360_calib_results.txt, rate_hz: 10}
marker: {dictionary: DICT_4X4_50, id: 7, size_m: 0.2}
cameras: {count: 1, calibration: ceiling_camera_640x360_ros.yaml, rate_hz: 0.5, store_radius_m: 0.3, lateral_offset_max_m: 0.1}
render: {fisheye_supersampling: 1, env_supersampling: 1}
)";
}

}  // namespace

fs::path testDirectory(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("lookboth_vo_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  folders().made.push_back(dir);
  return dir;
}

fs::path renderedScene(const Scene& scene) {
  const std::string key = scene.name + "|" + scene.loop + "|" + std::to_string(scene.wait_s) + "|" +
                          std::to_string(scene.duration_s);
  auto& scenes = folders().scenes;
  if (auto it = scenes.find(key); it != scenes.end()) return it->second;
  const fs::path dir = testDirectory("scene_" + scene.name);
  const fs::path scenario = dir / (scene.name + ".yaml");
  writeScenario(scenario, scene);
  sim::SimulateOptions options;
  options.scenario = scenario.string();
  options.out = dir / "data.rawlog";
  options.max_duration_s = scene.duration_s;
  options.overwrite = true;
  sim::simulate(options, ProgressReporter());
  scenes[key] = options.out;
  return options.out;
}

fs::path sceneScenario(const Scene& scene) {
  return renderedScene(scene).parent_path() / (scene.name + ".yaml");
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

}  // namespace lookboth::vo::scenes
