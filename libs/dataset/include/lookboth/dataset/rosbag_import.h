// ROS bag -> lookboth dataset (doc/formats.md, "ROS bag import").
//
// Reads a ROS 1 bag (format 2.0, with Debian's rosbag_storage library) or a
// ROS 2 bag (rosbag2: MCAP or sqlite3 storage, a bag folder with its
// metadata.yaml or one .mcap / .db3 file; CDR messages), no ROS installation
// needed, and writes a dataset (rawlog or folder) through DatasetWriter.
// Topics are mapped to lookboth labels and roles by the user:
//
//   message type (ROS 2: pkg/msg/Type)  role                     becomes
//   sensor_msgs/Image                   fisheye | env_camera     ImageFrame, as PNG (lossless)
//   sensor_msgs/CompressedImage         fisheye | env_camera     ImageFrame, the bytes as they are
//   sensor_msgs/CameraInfo              fisheye | env_camera     the camera's calibration
//   nav_msgs/Odometry                   odometry | ground_truth  PoseSample (world_from_body)
//   geometry_msgs/PoseStamped           odometry | ground_truth  PoseSample
//   geometry_msgs/PoseWithCovarianceStamped  odometry | ground_truth  PoseSample
//   tf2_msgs/TFMessage (/tf)            odometry | ground_truth  PoseSample: the transforms to
//                                                                the mapping's child_frame
//   tf2_msgs/TFMessage (/tf_static)     (read when a mapping has a body_frame: the mounts)
//
// Times are header.stamp (sec, nsec) -> TimeNs exactly, or the bag's receive
// time when `use_header_stamp` is false.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/dataset/manifest.h"

namespace lookboth {

/// One bag topic and what it is in the dataset.
struct RosTopicMapping {
  std::string topic;  ///< Bag topic, e.g. "/cam03/image/compressed".
  /// Camera or trajectory label. Camera info topics take the label of their
  /// camera. May be empty for the roles with a default label: fisheye ->
  /// "fisheye", odometry -> "odometry", ground_truth -> "ground_truth" (the
  /// only label allowed for that role).
  std::string label;
  std::string role;  ///< "fisheye" | "env_camera" | "odometry" | "ground_truth".
  /// Trajectories only: false when the poses are known up to an unknown scale
  /// (monocular VO).
  bool metric = true;
  /// tf2_msgs/TFMessage topics only: the frame whose pose becomes the
  /// trajectory (a transform's child_frame_id, e.g. "base_link").
  std::string child_frame;
  /// With child_frame: the transform's parent (header.frame_id, e.g. "odom");
  /// empty takes the child's transforms from any parent.
  std::string parent_frame;
  /// Trajectories of nav_msgs/Odometry or /tf: the frame whose poses the
  /// dataset is to hold, e.g. the fisheye's ("fisheye_link"), when the
  /// messages give another one (Odometry's child_frame_id, the transform's
  /// child, e.g. "base_link"). The poses are carried to it through the static
  /// transforms of the bag's /tf_static (world_from_body = world_from_child *
  /// child_from_body). Empty: the poses as they are.
  std::string body_frame;
};

/// Roles accepted in RosTopicMapping::role.
const std::vector<std::string>& rosTopicRoles();

struct RosbagImportOptions {
  std::vector<RosTopicMapping> topics;  ///< Which topics to import and as what.
  MarkerSpec marker;                    ///< The robot's marker.
  /// Camera label -> calibration file (any format of loadCamera); overrides
  /// the camera's CameraInfo topic.
  std::map<std::string, std::filesystem::path> calibration_files;
  /// Time of a record: the message's header.stamp (true) or the time the bag
  /// recorder received it (false).
  bool use_header_stamp = true;
  /// Called with each warning (CameraInfo changing during the recording,
  /// duplicated stamps...); when unset, warnings go to stderr as
  /// "lookboth: warning: ...". Warnings are also in RosbagImportStats.
  std::function<void(const std::string&)> on_warning;

  /// Empty when valid; else a message naming the field, e.g.
  /// "'topics[/odom].role': unknown role 'odom' (known: ...)".
  std::string check() const;
  /// The label a mapping gets (its own, or its role's default).
  static std::string effectiveLabel(const RosTopicMapping& mapping);
};

/// Reads a mapping YAML (doc/formats.md, "ROS bag import"):
///
///     topics:
///       /fisheye/image_raw:      {label: fisheye, role: fisheye}
///       /fisheye/camera_info:    {label: fisheye, role: fisheye}
///       /cam03/image/compressed: {label: cam03, role: env_camera}
///       /odom:                   {label: odometry, role: odometry, metric: true}
///       /tf:                     {label: ground_truth, role: ground_truth,
///                                 child_frame: base_link, parent_frame: map,
///                                 body_frame: fisheye_link}   # through /tf_static
///     marker: {dictionary: DICT_4X4_50, id: 0, size_m: 0.2}
///     calibrations: {cam03: path/relative/to/this/yaml}    # optional
///     use_header_stamp: true                               # optional
///
/// Throws lookboth::Error naming the file, the line and the field.
RosbagImportOptions loadRosbagMapping(const std::filesystem::path& yaml);

/// Parses the command-line form "/topic=label:role", "/topic=label:role:nonmetric"
/// (a trajectory up to scale) or "/topic=:role" (the role's default label);
/// a /tf topic names its frames: "/tf=label:role:child=base_link[:parent=odom]";
/// a trajectory carried to another frame through /tf_static: ":body=fisheye_link".
/// Throws lookboth::Error quoting the text.
RosTopicMapping parseTopicMapping(const std::string& text);

struct RosbagImportStats {
  /// Messages read per mapped topic (including camera info and skipped ones).
  std::map<std::string, std::int64_t> messages_per_topic;
  std::int64_t records = 0;           ///< Records written to the dataset.
  std::vector<std::string> warnings;  ///< Every warning given.
};

/// Reads `bag` message by message (memory stays flat), converts the mapped
/// topics and writes a dataset at `out` (the .rawlog for kRawlog, the folder
/// for kFolder; name = the output's stem). Reports progress per message
/// (stage "import") and honours stop requests (StopRequested; nothing is left
/// at `out`). Throws lookboth::Error, with nothing left at `out`, when the bag
/// cannot be read, a mapped topic is missing or of an unsupported type, an
/// image encoding is unsupported, an image's size differs from its camera's
/// calibration, or a pose is not finite / not a unit quaternion.
RosbagImportStats importRosbag(const std::filesystem::path& bag, const std::filesystem::path& out,
                               DatasetKind kind, const RosbagImportOptions& options,
                               const DatasetWriteOptions& write_options,
                               const ProgressReporter& progress);

}  // namespace lookboth
