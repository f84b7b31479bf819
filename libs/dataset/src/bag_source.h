// The messages of a ROS bag, ROS 1 or ROS 2, as the importer sees them
// (rosbag_import.cpp): topics with their types, and messages decoded into the
// ROS 1 C++ message structs, whichever format stored them. The ROS 1 source
// (ros1_bag_source.cpp) reads through rosbag_storage after checking the bag's
// structure; the ROS 2 source (ros2_bag_source.cpp) through ros2_bag.h and
// ros2_cdr.h.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "lookboth/geometry/time.h"

namespace lookboth::bag {

/// Why a message cannot be converted; the caller adds the bag, topic and message.
struct Problem {
  explicit Problem(std::string why_) : why(std::move(why_)) {}
  std::string why;
};

enum class MessageKind {
  kImage,
  kCompressedImage,
  kCameraInfo,
  kOdometry,
  kPoseStamped,
  kPoseWithCovarianceStamped,
  kTransforms,  ///< tf2_msgs/TFMessage (/tf, /tf_static)
};

/// The kind of a message type, by its ROS 1 name ("sensor_msgs/Image") or
/// its ROS 2 name ("sensor_msgs/msg/Image"); nothing for the types lookboth
/// does not read.
std::optional<MessageKind> kindOfType(const std::string& type);

/// The types lookboth reads, by the names of one format (ROS 2: true).
std::vector<std::string> supportedTypeNames(bool ros2);

TimeNs rosTimeToNs(const ros::Time& t);

/// One stored message. The decoders throw Problem when the bytes are not a
/// valid message of that type (a corrupt bag, another definition of it).
class BagMessage {
 public:
  virtual ~BagMessage() = default;
  virtual const std::string& topic() const = 0;
  /// When the recorder received it.
  virtual TimeNs receiveTime() const = 0;
  virtual sensor_msgs::Image image() const = 0;
  virtual sensor_msgs::CompressedImage compressedImage() const = 0;
  virtual sensor_msgs::CameraInfo cameraInfo() const = 0;
  virtual nav_msgs::Odometry odometry() const = 0;
  virtual geometry_msgs::PoseStamped poseStamped() const = 0;
  virtual geometry_msgs::PoseWithCovarianceStamped poseWithCovarianceStamped() const = 0;
  virtual std::vector<geometry_msgs::TransformStamped> transforms() const = 0;
};

/// A bag opened for reading. Errors are lookboth::Error naming the bag.
class BagSource {
 public:
  virtual ~BagSource() = default;
  /// "ROS 1 bag", "ROS 2 bag (MCAP)", ...: for messages.
  virtual std::string formatName() const = 0;
  /// True for ROS 2 (type names like sensor_msgs/msg/Image).
  virtual bool ros2() const = 0;
  /// Topic -> the message types it carries.
  virtual std::map<std::string, std::set<std::string>> topicTypes() = 0;
  /// Messages on these topics; -1 when the bag does not say.
  virtual std::int64_t count(const std::vector<std::string>& topics) = 0;
  /// Calls `visit` for each message on these topics, in the bag's order,
  /// until it returns false.
  virtual void forEach(const std::vector<std::string>& topics,
                       const std::function<bool(const BagMessage&)>& visit) = 0;
  /// What the reader found that does not stop the import (one warning each).
  virtual std::vector<std::string> notes() const { return {}; }
};

/// True for what is a ROS 2 bag by its form: a folder, an .mcap or a .db3 file.
bool looksLikeRos2Bag(const std::filesystem::path& path);

std::unique_ptr<BagSource> openRos1Bag(const std::filesystem::path& path);
std::unique_ptr<BagSource> openRos2Bag(const std::filesystem::path& path);

}  // namespace lookboth::bag
