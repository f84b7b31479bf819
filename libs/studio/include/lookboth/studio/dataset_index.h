// What the desktop app shows of a dataset, held in memory: the manifest, where
// each frame's image is (not the pixels), the detections and the
// trajectories, indexed by camera and time. Built by one streaming pass over
// the dataset; the views query it and never read the dataset themselves.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/records.h"
#include "lookboth/geometry/trajectory.h"

namespace lookboth::studio {

/// One frame of one camera: its time and where its encoded image is.
struct FrameRef {
  TimeNs t = 0;
  ImageFrame image;  ///< As read (file path, or encoded bytes for in-memory datasets).
};

/// Per environment camera: what the dataset holds about it.
struct CameraSummary {
  std::string label;
  bool has_calibration = false;
  std::int64_t frames = 0;      ///< Stored frames.
  std::int64_t detections = 0;  ///< Marker observations.
  TimeNs first_detection = 0;   ///< Valid when detections > 0.
  TimeNs last_detection = 0;
};

class DatasetIndex {
 public:
  /// Reads the whole dataset once (images are not decoded). Issues of the
  /// input (skipped records) are kept in `issues()`; unreadable input throws
  /// lookboth::Error naming the file, a stop throws StopRequested.
  static DatasetIndex build(const std::filesystem::path& dataset,
                            const ProgressReporter& progress = {});

  const std::filesystem::path& path() const { return path_; }
  const Manifest& manifest() const { return manifest_; }
  const std::vector<DatasetIssue>& issues() const { return issues_; }

  /// Fisheye frames in time order (empty for a detections-only dataset).
  const std::vector<FrameRef>& fisheyeFrames() const { return fisheye_frames_; }
  /// Frames of an environment camera in time order (empty when none or unknown).
  const std::vector<FrameRef>& cameraFrames(const std::string& label) const;
  /// The robot marker's observations by an environment camera in time order.
  const std::vector<MarkerObservation>& markers(const std::string& label) const;
  /// Observations of the other markers (fixed in the facility: control
  /// points "marker:<id>"), of every camera, in the dataset's order.
  const std::vector<MarkerObservation>& fixedMarkers() const { return fixed_markers_; }
  /// Blob observations (fisheye) in time order.
  const std::vector<BlobObservation>& blobs() const { return blobs_; }
  /// The blob observation stamped exactly t, or nullptr.
  const BlobObservation* blobsAt(TimeNs t) const;
  /// Trajectories by label (as in the manifest).
  const std::map<std::string, Trajectory>& trajectories() const { return trajectories_; }
  const Trajectory* trajectory(const std::string& label) const;

  /// One row per environment camera of the manifest, in manifest order.
  std::vector<CameraSummary> cameraSummaries() const;

  /// Count of records by kind ("image", "marker", "blobs", "pose").
  const std::map<std::string, std::int64_t>& recordCounts() const { return record_counts_; }

 private:
  std::filesystem::path path_;
  Manifest manifest_;
  std::vector<DatasetIssue> issues_;
  std::vector<FrameRef> fisheye_frames_;
  std::map<std::string, std::vector<FrameRef>> camera_frames_;
  std::map<std::string, std::vector<MarkerObservation>> markers_;
  std::vector<MarkerObservation> fixed_markers_;
  std::vector<BlobObservation> blobs_;
  std::map<std::string, Trajectory> trajectories_;
  std::map<std::string, std::int64_t> record_counts_;
};

}  // namespace lookboth::studio

namespace cv {
class Mat;
}

namespace lookboth::studio {
/// Decodes a frame's image (8-bit grey or BGR). Throws lookboth::Error naming
/// the file when it is missing or not an image.
cv::Mat decodeFrame(const ImageFrame& frame);
}  // namespace lookboth::studio
