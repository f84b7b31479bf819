// `lookboth convert`: between the rawlog dataset, the plain folder layout and
// TUM trajectory files. (ROS bags are imported by rosbag_import.h.)
#pragma once

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/geometry/time.h"

namespace lookboth {

enum class DataKind { kAuto, kRawlog, kFolder, kBag, kTum };
const char* dataKindName(DataKind kind);
/// "rawlog", "folder", "bag", "tum" (or "auto") to a kind; nullopt otherwise.
std::optional<DataKind> parseDataKind(const std::string& name);
/// From the path: ".rawlog" (or its manifest) -> rawlog, ".bag", ".mcap", ".db3", a folder with
/// a metadata.yaml (rosbag2) -> bag, ".tum"/".txt" -> tum,
/// a directory or no extension -> folder. Throws lookboth::Error naming the path otherwise.
DataKind detectDataKind(const std::filesystem::path& path);

/// A TUM trajectory to add to the output dataset.
struct TrajectoryInput {
  std::filesystem::path file;
  TrajectoryInfo info;  ///< label, metric, description
};

/// A camera's frames from a video file (`--video`), added to a dataset output.
struct VideoInput {
  std::string label;            ///< The camera (in the input, or added with `calibration`).
  std::filesystem::path file;   ///< The video (any container and codec FFmpeg reads).
  std::filesystem::path times;  ///< Sidecar CSV `timestamp_ns[,frame]`; empty: the container's.
  std::optional<TimeNs> start;  ///< With the container's times: the first frame's time [ns].
  std::filesystem::path
      calibration;  ///< For a camera the input does not have (an environment camera).
};

struct ConvertOptions {
  std::filesystem::path from;
  std::filesystem::path to;
  DataKind from_kind = DataKind::kAuto;
  DataKind to_kind = DataKind::kAuto;
  bool overwrite = false;  ///< Replace an existing output.
  bool strict = false;     ///< Input issues (duplicates, missing images...) are errors.
  /// dataset -> TUM: which trajectory to write; empty = "odometry" if present,
  /// else the only trajectory. TUM -> dataset: the label given to it (default "odometry").
  std::string trajectory_label;
  /// TUM -> dataset: whether the trajectory is metric.
  bool trajectory_metric = true;
  /// Extra TUM trajectories added to a dataset output.
  std::vector<TrajectoryInput> add_trajectories;
  /// dataset -> dataset: only these cameras (labels), what one camera's edge
  /// node holds: their frames and detections, calibrations and ground truth;
  /// no trajectories. Empty = every camera and trajectory.
  std::vector<std::string> cameras;
  /// dataset -> dataset: cameras whose frames come from video files; a frame
  /// the input has for such a camera is dropped (the video replaces them).
  std::vector<VideoInput> videos;
  /// Called for every input issue as it is found (e.g. to print a warning).
  std::function<void(const DatasetIssue&)> on_issue;
  /// Empty when valid; else a message naming the option.
  std::string check() const;
};

/// The input and output kinds of a conversion: the forced ones, else those
/// detected from the paths (an output "x.rawlog" need not exist yet).
std::pair<DataKind, DataKind> resolveDataKinds(const ConvertOptions& options);

struct ConvertSummary {
  std::map<std::string, std::int64_t> records;  ///< by kind ("image", "marker", "blobs", "pose")
  std::vector<DatasetIssue> issues;             ///< warnings found in the input
  std::int64_t total() const;
};

/// Runs a conversion; outputs appear only when complete. Throws
/// lookboth::Error on bad input or options, StopRequested when stopped.
ConvertSummary convertData(const ConvertOptions& options, const ProgressReporter& progress);

}  // namespace lookboth
