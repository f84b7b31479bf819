#include "ros2_cdr.h"

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/BadParamException.h>
#include <fastcdr/exceptions/NotEnoughMemoryException.h>

#include <algorithm>
#include <cstdio>

namespace lookboth::ros2 {

namespace {

namespace fastcdr = eprosima::fastcdr;

/// Reads the fields of one message in order through Fast CDR, naming the
/// field (dotted, e.g. "pose.pose.position.x") and the byte in every error.
class Decoder {
 public:
  explicit Decoder(const Cdr& cdr);

  /// A named level of nesting ("header", "pose"), for the fields' names.
  class Scope {
   public:
    Scope(Decoder& decoder, const char* name) : decoder_(decoder) {
      decoder_.scopes_.push_back(name);
    }
    ~Scope() { decoder_.scopes_.pop_back(); }
    Scope(const Scope&) = delete;
    Scope& operator=(const Scope&) = delete;

   private:
    Decoder& decoder_;
  };

  /// A primitive or a string.
  template <class T>
  void read(const char* field, T* value) {
    guarded(field, [&] { cdr_ >> *value; });
  }
  /// A fixed-size array, e.g. float64[9].
  template <class T>
  void readArray(const char* field, T* values, std::size_t count) {
    guarded(field, [&] { cdr_.deserializeArray(values, count); });
  }
  /// A sequence of primitives, e.g. uint8[] or float64[].
  template <class T>
  void readSequence(const char* field, std::vector<T>* values) {
    const std::uint32_t length = readLength(field, sizeof(T));
    values->resize(length);
    if (length > 0) readArray(field, values->data(), length);
  }
  /// A sequence's length, checked against the bytes left, `element_size`
  /// bytes at least per element.
  std::uint32_t readLength(const char* field, std::size_t element_size);
  [[noreturn]] void invalid(const char* field, const std::string& why) const;

 private:
  template <class Read>
  void guarded(const char* field, const Read& read) {
    try {
      read();
    } catch (const fastcdr::exception::NotEnoughMemoryException&) {
      throw DecodeError("truncated in field '" + path(field) + "' at byte " +
                        std::to_string(position()) + " of " + std::to_string(size_));
    } catch (const fastcdr::exception::Exception& e) {
      invalid(field, e.what());
    }
  }
  std::size_t position() const { return cdr_.getSerializedDataLength(); }
  std::string path(const char* field) const;

  std::size_t size_;
  // Fast CDR wants a mutable buffer but only reads it when deserializing.
  fastcdr::FastBuffer buffer_;
  fastcdr::Cdr cdr_;
  std::vector<const char*> scopes_;
};

Decoder::Decoder(const Cdr& cdr)
    : size_(cdr.size()),
      buffer_(reinterpret_cast<char*>(const_cast<std::uint8_t*>(cdr.data())), cdr.size()),
      cdr_(buffer_, fastcdr::Cdr::DEFAULT_ENDIAN, fastcdr::Cdr::DDS_CDR) {
  if (cdr.size() < 4) {
    throw DecodeError("truncated in the encapsulation header: " + std::to_string(cdr.size()) +
                      " bytes, a CDR message starts with 4");
  }
  if (cdr[0] != 0 || cdr[1] > 1) {
    char kind[16];
    std::snprintf(kind, sizeof(kind), "0x%02x%02x", cdr[0], cdr[1]);
    throw DecodeError(std::string("unknown encapsulation ") + kind +
                      " at byte 0 (expected 0x0000 CDR big-endian or 0x0001 CDR little-endian)");
  }
  guarded("encapsulation", [&] { cdr_.read_encapsulation(); });
}

std::string Decoder::path(const char* field) const {
  std::string out;
  for (const char* scope : scopes_) out += std::string(scope) + ".";
  return out + field;
}

void Decoder::invalid(const char* field, const std::string& why) const {
  throw DecodeError("bad value in field '" + path(field) + "' at byte " +
                    std::to_string(position()) + " of " + std::to_string(size_) + ": " + why);
}

std::uint32_t Decoder::readLength(const char* field, std::size_t element_size) {
  std::uint32_t length = 0;
  read(field, &length);
  const std::size_t left = size_ - position();
  if (length > left / element_size) {
    throw DecodeError("truncated in field '" + path(field) + "' at byte " +
                      std::to_string(position()) + " of " + std::to_string(size_) + ": " +
                      std::to_string(length) + " elements need " +
                      std::to_string(std::uint64_t{length} * element_size) + " bytes, " +
                      std::to_string(left) + " remain");
  }
  return length;
}

// ---------------------------------------------------------------------------
// The ROS 2 message layouts, field by field.

void readTime(Decoder& decoder, ros::Time* time) {
  Decoder::Scope scope(decoder, "stamp");
  std::int32_t sec = 0;
  std::uint32_t nanosec = 0;
  decoder.read("sec", &sec);
  if (sec < 0) decoder.invalid("sec", std::to_string(sec) + " is before 1970 (ROS 1 time)");
  decoder.read("nanosec", &nanosec);
  if (nanosec >= 1000000000u) decoder.invalid("nanosec", std::to_string(nanosec) + " >= 1e9");
  time->sec = static_cast<std::uint32_t>(sec);
  time->nsec = nanosec;
}

void readHeader(Decoder& decoder, std_msgs::Header* header) {
  Decoder::Scope scope(decoder, "header");
  readTime(decoder, &header->stamp);
  decoder.read("frame_id", &header->frame_id);
}

template <class Vector>
void readVector3(Decoder& decoder, const char* name, Vector* vector) {
  Decoder::Scope scope(decoder, name);
  decoder.read("x", &vector->x);
  decoder.read("y", &vector->y);
  decoder.read("z", &vector->z);
}

void readQuaternion(Decoder& decoder, const char* name, geometry_msgs::Quaternion* quaternion) {
  Decoder::Scope scope(decoder, name);
  decoder.read("x", &quaternion->x);
  decoder.read("y", &quaternion->y);
  decoder.read("z", &quaternion->z);
  decoder.read("w", &quaternion->w);
}

void readPose(Decoder& decoder, geometry_msgs::Pose* pose) {
  Decoder::Scope scope(decoder, "pose");
  readVector3(decoder, "position", &pose->position);
  readQuaternion(decoder, "orientation", &pose->orientation);
}

void readPoseWithCovariance(Decoder& decoder, geometry_msgs::PoseWithCovariance* pose) {
  Decoder::Scope scope(decoder, "pose");
  readPose(decoder, &pose->pose);
  decoder.readArray("covariance", pose->covariance.data(), pose->covariance.size());
}

void readTwistWithCovariance(Decoder& decoder, geometry_msgs::TwistWithCovariance* twist) {
  Decoder::Scope scope(decoder, "twist");
  {
    Decoder::Scope inner(decoder, "twist");
    readVector3(decoder, "linear", &twist->twist.linear);
    readVector3(decoder, "angular", &twist->twist.angular);
  }
  decoder.readArray("covariance", twist->covariance.data(), twist->covariance.size());
}

void readTransformStamped(Decoder& decoder, geometry_msgs::TransformStamped* transform) {
  readHeader(decoder, &transform->header);
  decoder.read("child_frame_id", &transform->child_frame_id);
  Decoder::Scope scope(decoder, "transform");
  readVector3(decoder, "translation", &transform->transform.translation);
  readQuaternion(decoder, "rotation", &transform->transform.rotation);
}

void readRegionOfInterest(Decoder& decoder, sensor_msgs::RegionOfInterest* roi) {
  Decoder::Scope scope(decoder, "roi");
  decoder.read("x_offset", &roi->x_offset);
  decoder.read("y_offset", &roi->y_offset);
  decoder.read("height", &roi->height);
  decoder.read("width", &roi->width);
  bool do_rectify = false;
  decoder.read("do_rectify", &do_rectify);
  roi->do_rectify = do_rectify ? 1 : 0;
}

}  // namespace

const std::vector<std::string>& supportedTypes() {
  static const std::vector<std::string> kTypes = {
      "sensor_msgs/msg/Image",         "sensor_msgs/msg/CompressedImage",
      "sensor_msgs/msg/CameraInfo",    "nav_msgs/msg/Odometry",
      "geometry_msgs/msg/PoseStamped", "geometry_msgs/msg/PoseWithCovarianceStamped",
      "tf2_msgs/msg/TFMessage",
  };
  return kTypes;
}

bool isSupportedType(const std::string& ros2_type) {
  const std::vector<std::string>& types = supportedTypes();
  return std::find(types.begin(), types.end(), ros2_type) != types.end();
}

sensor_msgs::Image decodeImage(const Cdr& cdr) {
  Decoder decoder(cdr);
  sensor_msgs::Image image;
  readHeader(decoder, &image.header);
  decoder.read("height", &image.height);
  decoder.read("width", &image.width);
  decoder.read("encoding", &image.encoding);
  decoder.read("is_bigendian", &image.is_bigendian);
  decoder.read("step", &image.step);
  decoder.readSequence("data", &image.data);
  return image;
}

sensor_msgs::CompressedImage decodeCompressedImage(const Cdr& cdr) {
  Decoder decoder(cdr);
  sensor_msgs::CompressedImage image;
  readHeader(decoder, &image.header);
  decoder.read("format", &image.format);
  decoder.readSequence("data", &image.data);
  return image;
}

sensor_msgs::CameraInfo decodeCameraInfo(const Cdr& cdr) {
  Decoder decoder(cdr);
  sensor_msgs::CameraInfo info;
  readHeader(decoder, &info.header);
  decoder.read("height", &info.height);
  decoder.read("width", &info.width);
  decoder.read("distortion_model", &info.distortion_model);
  decoder.readSequence("d", &info.D);
  decoder.readArray("k", info.K.data(), info.K.size());
  decoder.readArray("r", info.R.data(), info.R.size());
  decoder.readArray("p", info.P.data(), info.P.size());
  decoder.read("binning_x", &info.binning_x);
  decoder.read("binning_y", &info.binning_y);
  readRegionOfInterest(decoder, &info.roi);
  return info;
}

nav_msgs::Odometry decodeOdometry(const Cdr& cdr) {
  Decoder decoder(cdr);
  nav_msgs::Odometry odometry;
  readHeader(decoder, &odometry.header);
  decoder.read("child_frame_id", &odometry.child_frame_id);
  readPoseWithCovariance(decoder, &odometry.pose);
  readTwistWithCovariance(decoder, &odometry.twist);
  return odometry;
}

geometry_msgs::PoseStamped decodePoseStamped(const Cdr& cdr) {
  Decoder decoder(cdr);
  geometry_msgs::PoseStamped pose;
  readHeader(decoder, &pose.header);
  readPose(decoder, &pose.pose);
  return pose;
}

geometry_msgs::PoseWithCovarianceStamped decodePoseWithCovarianceStamped(const Cdr& cdr) {
  Decoder decoder(cdr);
  geometry_msgs::PoseWithCovarianceStamped pose;
  readHeader(decoder, &pose.header);
  readPoseWithCovariance(decoder, &pose.pose);
  return pose;
}

std::vector<geometry_msgs::TransformStamped> decodeTfMessage(const Cdr& cdr) {
  Decoder decoder(cdr);
  // A TransformStamped takes 64 bytes at least (stamp, two string lengths,
  // seven float64), which bounds the count a corrupt length can ask for.
  const std::uint32_t count = decoder.readLength("transforms", 64);
  std::vector<geometry_msgs::TransformStamped> transforms(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::string name = "transforms[" + std::to_string(i) + "]";
    Decoder::Scope scope(decoder, name.c_str());
    readTransformStamped(decoder, &transforms[i]);
  }
  return transforms;
}

}  // namespace lookboth::ros2
