// `lookboth detect`: marker observations from the environment cameras' frames
// and blob observations from the fisheye's, added to the dataset
// (augmentDataset: a new dataset swapped in when complete).
//
// Reading is sequential; decoding and detection run on a pool of worker
// threads, one job per environment camera (its frames in time order: a
// camera's track predicts where to look next and resolves the pose
// ambiguity) and one job per chunk of fisheye frames. The output does not
// depend on the number of threads.
#pragma once
#include <yaml-cpp/yaml.h>
#include "lookboth/core/config_layers.h"

#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/augment.h"
#include "lookboth/detect/blob_detector.h"
#include "lookboth/detect/marker_detector.h"
#include "lookboth/geometry/time.h"

namespace lookboth {

/// The `detect:` section of a lookboth configuration file (doc/formats.md).
struct DetectConfig {
  MarkerDetectorOptions markers;
  BlobDetectorOptions blobs;
  std::string check() const;
};

/// Reads the `detect:` section (`markers:`, `blobs:`) of a YAML configuration
/// over `base` (keys absent keep their value); the other sections
/// (`register:`, `odometry:`) are left to their owners; an unknown section or
/// key is an error naming the file, line and field.
DetectConfig loadDetectConfig(const std::filesystem::path& yaml, const DetectConfig& base = {});
/// share/lookboth/config/default.yaml's section over the compiled defaults.
DetectConfig defaultDetectConfig();
/// The `detect:` section that loadDetectConfig reads back as `config`
/// ({markers: {...}, blobs: {...}}, every key).
YAML::Node detectConfigYaml(const DetectConfig& config);
/// The `detect:` sections of the configuration's layers (core/config_layers.h),
/// each over the ones before, over the compiled defaults.
DetectConfig detectConfigFrom(const std::vector<ConfigLayer>& layers);
/// The configuration a command uses: default.yaml, then the user's file
/// (when given) over it, as `register:` is layered.
DetectConfig detectConfigFor(const std::optional<std::filesystem::path>& user_file);

struct DetectOptions {
  std::filesystem::path dataset;  ///< Input dataset (.rawlog or folder).
  std::filesystem::path out;      ///< Output; empty = replace the input.
  bool overwrite = false;         ///< Replace an existing `out`.
  /// Cameras to process (labels); empty = every environment camera with a
  /// calibration, and the fisheye.
  std::vector<std::string> cameras;
  int threads = 0;  ///< Worker threads; 0 = one per hardware thread.
  bool markers = true;
  bool blobs = true;
  /// The output holds the detections alone (no frames, no trajectories): the
  /// kilobytes an edge node sends back for `lookboth convert --merge`. Needs `out`.
  bool detections_only = false;
  DetectConfig config;
  std::function<void(const DatasetIssue&)> on_issue;  ///< Warnings (skipped frames...).
  std::string check() const;
};

struct CameraDetectSummary {
  std::string camera;
  bool fisheye = false;
  std::int64_t frames = 0;  ///< Frames read.
  /// Frames searched for the marker: all of them, or with a coarse search
  /// (MarkerDetectorOptions::coarse_period_s) those around the passes.
  std::int64_t examined = 0;
  /// Of `examined`, coarse frames decoded but not searched: the view had not
  /// changed since the last one searched (coarse_change_grey).
  std::int64_t unchanged = 0;
  /// Coarse key frames searched as previews (coarse_key_frame_previews).
  std::int64_t previews = 0;
  /// The coarse frames were its video's key frames (coarse_key_frames_max_s).
  bool coarse_key_frames = false;
  std::int64_t skipped = 0;     ///< Frames that could not be decoded.
  std::int64_t detections = 0;  ///< The robot marker's observations, or blob records.
  /// Observations of the markers fixed in the facility (fixed_marker_sizes_m).
  std::int64_t fixed_markers = 0;
  std::int64_t blobs = 0;       ///< Blobs in all (fisheye).
  std::int64_t ambiguous = 0;   ///< Markers ambiguous from their frame alone.
  std::int64_t unresolved = 0;  ///< ... and not resolved by the track (best-fitting pose kept).
  std::int64_t rejected = 0;    ///< Markers inconsistent with the camera's track (false positives).
  /// The marker's candidates in its frames: edge fits, fallbacks to OpenCV's
  /// corners and rejections, each with its reason.
  MarkerDetectorStats marker_candidates;
  /// The fisheye's blob candidates: kept, or dropped with their reason.
  BlobDetectorStats blob_candidates;
};

struct DetectSummary {
  std::vector<CameraDetectSummary> cameras;
  AugmentSummary written;
  std::vector<DatasetIssue> issues;
  /// Every environment-camera frame (camera, stamp), examined or not: one
  /// the coarse search skipped that shows the marker counts as missed.
  std::vector<std::pair<std::string, TimeNs>> searched;
  double detect_seconds = 0;  ///< Wall time of decoding + detection.
};

/// Runs detection and writes the result. Throws lookboth::Error on bad
/// input (naming the file and camera), StopRequested when stopped (nothing
/// written, the input untouched).
DetectSummary detectDataset(const DetectOptions& options, const ProgressReporter& progress);

/// Writes records from `runDetection` into the dataset (options.out, or in
/// place): the detections already there for the cameras of `summary` are
/// replaced, everything else is kept.
AugmentSummary writeDetections(const DetectOptions& options, std::vector<Record> records,
                               const DetectSummary& summary, const ProgressReporter& progress);

/// The fisheye's blob search fed frame by frame by whoever decodes the
/// frames: `register` gives it the frames its odometry decodes, so that each
/// is decoded once for both. It searches the frames runDetection would
/// (blobs.max_rate_hz) and gives the same records and counts provided every
/// fisheye frame is offered to wants() in time order, which the caller
/// checks (a rawlog may hold frames out of order; runDetection sorts them).
class FisheyeBlobSearch {
 public:
  /// Throws lookboth::Error when the configuration's blob options are wrong.
  FisheyeBlobSearch(const CameraSensor& fisheye, const DetectConfig& config);
  /// Whether the frame at `t` is searched; counts the frame.
  bool wants(TimeNs t);
  /// Searches a frame wants() chose (8-bit grey); one of the wrong size
  /// (a caller that did not check it) is skipped with its reason.
  void search(const ImageFrame& frame, const cv::Mat& grey);
  /// The blob records in the order searched, and the fisheye's summary.
  std::vector<Record> takeRecords() { return std::move(records_); }
  const CameraDetectSummary& summary() const { return summary_; }
  const std::vector<DatasetIssue>& issues() const { return issues_; }

 private:
  std::string label_;
  std::optional<Camera> camera_;
  BlobDetector detector_;
  RateLimiter rate_;
  std::vector<Record> records_;
  CameraDetectSummary summary_;
  std::vector<DatasetIssue> issues_;
};

/// Detection without writing: the records `detectDataset` would add (markers
/// in time order per camera, then blobs), for evaluation and benchmarks.
std::vector<Record> runDetection(const DetectOptions& options, const ProgressReporter& progress,
                                 DetectSummary* summary);

}  // namespace lookboth
