// `lookboth simulate`: a scenario -> a dataset with ground truth.
//
// What is written (doc/formats.md, "Scenario files", says how each piece is
// modelled):
//  - fisheye frames (PNG, rendered through the fisheye's model) at the
//    fisheye's rate, stamped in the robot's clock; with --detections-only a
//    BlobObservation per fisheye frame instead (the housings' centres
//    projected, plus pixel noise);
//  - environment-camera frames while the robot is within store_radius_m of
//    the point under the camera, stamped in that camera's clock; with
//    --detections-only a MarkerObservation per such frame in which the
//    marker is in view and facing the camera (truth + modelled noise, with
//    the information matrix of that noise);
//  - trajectories "ground_truth" (world_from_fisheye at the fisheye's frame
//    times, robot clock) and "odometry" (wheel odometry with drift);
//  - the manifest: cameras (fisheye first) with calibrations, the marker,
//    the trajectories and the ground truth (world_from_camera,
//    fisheye_from_marker, clock offsets).
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"

namespace lookboth::sim {

struct SimulateOptions {
  std::string scenario =
      "small";  ///< A built-in name (share/lookboth/scenarios/<name>.yaml) or a YAML file.
  std::filesystem::path out;  ///< The .rawlog (kRawlog) or the folder (kFolder).
  DatasetKind kind = DatasetKind::kRawlog;
  bool detections_only = false;       ///< Marker poses and blobs directly, no images.
  std::optional<std::uint32_t> seed;  ///< Overrides the scenario's seed.
  bool overwrite = false;
  /// Simulate only the first max_duration_s seconds [s]; 0 = the whole scenario (for tests).
  double max_duration_s = 0;
  /// Rendering threads; 0 = one per hardware thread. Results do not depend on it.
  int threads = 0;
  std::string check() const;
};

struct SimulateSummary {
  std::map<std::string, std::int64_t> records;  ///< By kind ("image", "marker", "blobs", "pose").
  int cameras = 0;                              ///< Environment cameras.
  double duration_s = 0;                        ///< Simulated time.
  double path_length_m = 0;                     ///< Robot path length (over the simulated time).
  std::uint32_t seed = 0;                       ///< The seed used.
  std::string scenario;                         ///< The scenario's name.
  std::uintmax_t output_bytes = 0;              ///< Size of everything written.
  std::vector<std::string> faults;              ///< What the faults did, one line each.
  std::int64_t total() const;
};

/// Runs the simulation and writes the dataset (atomically). Deterministic for
/// a given scenario and seed. Throws lookboth::Error on a bad scenario,
/// StopRequested when stopped.
SimulateSummary simulate(const SimulateOptions& options, const ProgressReporter& progress);

}  // namespace lookboth::sim
