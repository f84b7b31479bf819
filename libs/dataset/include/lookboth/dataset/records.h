// What a dataset holds over time: one record per measurement, in the
// sensor's own clock, as `TimeNs` nanoseconds (doc/conventions.md).
//
//   record              MRPT class in the rawlog            folder format (doc/formats.md)
//   ImageFrame          mrpt::obs::CObservationImage        fisheye/frames.csv,
//   cameras/<label>/frames.csv MarkerObservation   mrpt::obs::CObservation6DFeatures
//   detections/markers.csv BlobObservation     lookboth::CObservationBlobs detections/blobs.csv
//   PoseSample          mrpt::obs::CObservationRobotPose    odometry/trajectory.tum,
//   ground_truth/trajectory.tum,
//                                                           trajectories/<label>.tum
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/time.h"
#include "lookboth/obs/CObservationBlobs.h"

namespace lookboth {

/// One camera frame, kept encoded (PNG, JPEG...) so that conversions copy
/// bytes and lose nothing.
struct ImageFrame {
  TimeNs t = 0;
  std::string sensor;  ///< Camera label (the fisheye's or an environment camera's).
  /// Where the encoded image is on disk (absolute), when it is a file.
  std::filesystem::path image_file;
  /// Or the encoded bytes themselves (e.g. rendered by the simulator); when
  /// set, `image_file` is ignored and `extension` (".png", ".jpg") says the encoding.
  std::shared_ptr<const std::vector<std::uint8_t>> encoded;
  std::string extension;
  /// Or a frame of a video file (absolute path): the `video_frame`-th frame
  /// in presentation order, counted from 0. Decode any of the three with
  /// `FrameDecoder` (frame_decoder.h).
  std::filesystem::path video_file;
  std::int64_t video_frame = -1;
};

/// The robot's marker seen by an environment camera.
struct MarkerObservation {
  TimeNs t = 0;
  std::string camera;  ///< Environment camera label.
  int marker_id = 0;
  Rigid3d camera_from_marker;  ///< Pose of the marker in the camera frame [m].
  /// Information (inverse covariance) of the pose, over the perturbation
  /// [dt (3, m); dtheta (3, rad)] with t_true = t + dt, R_true = R * Exp(dtheta).
  /// All zero when the source gave none.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  /// The marker's four corners as found in the camera's image [px; pixel
  /// origin of doc/conventions.md], in the marker's corner order: marker-frame
  /// (-s/2, s/2, 0), (s/2, s/2, 0), (s/2, -s/2, 0), (-s/2, -s/2, 0) for a
  /// marker of side s (OpenCV ArUco's top-left, top-right, bottom-right,
  /// bottom-left). Empty when the source stored none; otherwise exactly 4.
  std::vector<Eigen::Vector2d> corners_px;
  /// Standard deviation of one corner coordinate [px], as measured by the
  /// detector; 0 when unknown.
  double corner_sigma_px = 0;
};

/// Blobs (environment cameras' housings) found in one fisheye frame.
struct BlobObservation {
  TimeNs t = 0;
  std::string camera;   ///< The camera whose frame holds the blobs (the fisheye).
  int image_width = 0;  ///< Frame size [px]; 0 when unknown.
  int image_height = 0;
  std::vector<Blob> blobs;
};

/// One sample of a trajectory: world_from_body at t. The trajectory is named
/// by `label` ("odometry", "ground_truth", "vo", ...; see the manifest).
struct PoseSample {
  TimeNs t = 0;
  std::string label;
  Rigid3d world_from_body;
};

using Record = std::variant<ImageFrame, MarkerObservation, BlobObservation, PoseSample>;

/// A detection's covariance over [dt; dtheta] (its information inverted);
/// nullopt when the source gave none or it cannot be inverted.
std::optional<Eigen::Matrix<double, 6, 6>> markerCovariance(const MarkerObservation& detection);

/// Time of any record.
TimeNs recordTime(const Record& record);
/// Sensor or trajectory label of any record.
const std::string& recordLabel(const Record& record);
/// "image", "marker", "blobs", "pose".
const char* recordKindName(const Record& record);

}  // namespace lookboth
