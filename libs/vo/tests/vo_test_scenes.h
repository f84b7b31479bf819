// Rendered test scenes of the odometry tests (shared by the test binaries of
// libs/vo): `small`'s room with a chosen robot loop, rendered once per test
// binary and reused by every test that asks for the same scene.
#pragma once

#include <filesystem>
#include <string>

#include "lookboth/geometry/trajectory.h"

namespace lookboth::vo::scenes {

struct Scene {
  std::string name;       ///< Folder and scenario name.
  std::string loop;       ///< The robot's loop, YAML list of [x, y] corners [m].
  double wait_s = 0.5;    ///< Standstill at the start [s].
  double duration_s = 0;  ///< Frames rendered [s]; 0 = the whole loop.
};

/// Renders the scene (fisheye 640x360 at 10 Hz, one environment camera)
/// into a fresh temporary folder the first time it is asked for, and
/// returns the dataset (`data.rawlog`); the same path afterwards. The
/// folders are removed when the test binary exits.
std::filesystem::path renderedScene(const Scene& scene);

/// The scenario file of a rendered scene (beside its dataset).
std::filesystem::path sceneScenario(const Scene& scene);

/// A fresh empty temporary folder for outputs of a test.
std::filesystem::path testDirectory(const std::string& name);

/// The dataset's `ground_truth` trajectory.
Trajectory groundTruth(const std::filesystem::path& dataset);

}  // namespace lookboth::vo::scenes
