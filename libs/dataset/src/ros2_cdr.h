// ROS 2 messages (CDR, as rosbag2 stores them) decoded into the ROS 1 C++
// message structs the ROS 1 bag import already uses, with eProsima Fast CDR.
//
// The input is the stored message: a 4-byte encapsulation header (0x00 0x00
// CDR big-endian, 0x00 0x01 CDR little-endian, two option bytes) and then
// the fields, aligned relative to the end of the header. ROS 2 names map to
// ROS 1 ones (CameraInfo d, k, r, p -> D, K, R, P); a ROS 2 Header has no
// seq (left 0) and a signed stamp.sec, which must not be negative here.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace lookboth::ros2 {

/// A message that does not decode: truncated, a bad length or value, an
/// unknown encapsulation. what() names the field and the byte, e.g.
/// "truncated in field 'data' at byte 57 of 64". Callers add the message's
/// place in the bag (Message::where).
class DecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The ROS 2 types decoded here: "sensor_msgs/msg/Image", ...
const std::vector<std::string>& supportedTypes();
bool isSupportedType(const std::string& ros2_type);

using Cdr = std::vector<std::uint8_t>;

sensor_msgs::Image decodeImage(const Cdr& cdr);                      // sensor_msgs/msg/Image
sensor_msgs::CompressedImage decodeCompressedImage(const Cdr& cdr);  // .../CompressedImage
sensor_msgs::CameraInfo decodeCameraInfo(const Cdr& cdr);            // .../CameraInfo
nav_msgs::Odometry decodeOdometry(const Cdr& cdr);                   // nav_msgs/msg/Odometry
geometry_msgs::PoseStamped decodePoseStamped(const Cdr& cdr);  // geometry_msgs/msg/PoseStamped
geometry_msgs::PoseWithCovarianceStamped decodePoseWithCovarianceStamped(const Cdr& cdr);
/// tf2_msgs/msg/TFMessage: its transforms.
std::vector<geometry_msgs::TransformStamped> decodeTfMessage(const Cdr& cdr);

}  // namespace lookboth::ros2
