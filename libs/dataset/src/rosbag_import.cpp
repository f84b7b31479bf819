#include "lookboth/dataset/rosbag_import.h"

#include <bzlib.h>
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>
#include <type_traits>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth {

namespace fs = std::filesystem;

namespace {

constexpr const char* kImageType = "sensor_msgs/Image";
constexpr const char* kCompressedImageType = "sensor_msgs/CompressedImage";
constexpr const char* kCameraInfoType = "sensor_msgs/CameraInfo";
constexpr const char* kOdometryType = "nav_msgs/Odometry";
constexpr const char* kPoseStampedType = "geometry_msgs/PoseStamped";

bool isCameraRole(const std::string& role) { return role == "fisheye" || role == "env_camera"; }
bool isTrajectoryRole(const std::string& role) {
  return role == "odometry" || role == "ground_truth";
}

std::string joined(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& item : items) out += (out.empty() ? "" : ", ") + item;
  return out;
}

std::string sizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

}  // namespace

// ---------------------------------------------------------------------------
// Options

const std::vector<std::string>& rosTopicRoles() {
  static const std::vector<std::string> kRoles = {"fisheye", "env_camera", "odometry",
                                                  "ground_truth"};
  return kRoles;
}

std::string RosbagImportOptions::effectiveLabel(const RosTopicMapping& mapping) {
  if (!mapping.label.empty()) return mapping.label;
  if (mapping.role == "fisheye" || mapping.role == "odometry" || mapping.role == "ground_truth") {
    return mapping.role;
  }
  return "";
}

std::string RosbagImportOptions::check() const {
  if (topics.empty()) return "'topics': no topic to import";
  std::set<std::string> seen_topics;
  // label -> (role, first topic)
  std::map<std::string, std::pair<std::string, std::string>> label_roles;
  std::string fisheye_label;
  for (size_t i = 0; i < topics.size(); ++i) {
    const RosTopicMapping& m = topics[i];
    if (m.topic.empty()) return "'topics[" + std::to_string(i) + "]': empty topic name";
    const std::string field = "topics[" + m.topic + "]";
    if (!seen_topics.insert(m.topic).second) return "'" + field + "': topic mapped twice";
    const auto& roles = rosTopicRoles();
    if (std::find(roles.begin(), roles.end(), m.role) == roles.end()) {
      return "'" + field + ".role': unknown role '" + m.role + "' (known: " + joined(roles) + ")";
    }
    const std::string label = effectiveLabel(m);
    if (label.empty()) return "'" + field + ".label': missing (required for role " + m.role + ")";
    if (label.find_first_of(",/\\ \t\n") != std::string::npos) {
      return "'" + field + ".label': '" + label + "' must not contain commas, slashes or spaces";
    }
    if (m.role == "ground_truth" && label != "ground_truth") {
      return "'" + field + ".label': a ground_truth topic has the label 'ground_truth', got '" +
             label + "'";
    }
    const auto [it, inserted] = label_roles.emplace(label, std::make_pair(m.role, m.topic));
    if (!inserted) {
      if (it->second.first != m.role) {
        return "'" + field + ".label': '" + label + "' is already the label of " +
               it->second.second + " with role " + it->second.first + " (one label, one role)";
      }
      if (isTrajectoryRole(m.role)) {
        return "'" + field + ".label': trajectory '" + label + "' already comes from " +
               it->second.second;
      }
    }
    if (m.role == "fisheye") {
      if (!fisheye_label.empty() && fisheye_label != label) {
        return "'" + field + ".label': a second fisheye '" + label + "' (the fisheye is '" +
               fisheye_label + "'; a dataset has one)";
      }
      fisheye_label = label;
    }
  }
  for (const auto& [label, path] : calibration_files) {
    const auto it = label_roles.find(label);
    if (it == label_roles.end() || !isCameraRole(it->second.first)) {
      return "'calibrations." + label + "': no camera topic has that label";
    }
    if (path.empty()) return "'calibrations." + label + "': empty path";
  }
  if (const std::string why = marker.check(); !why.empty()) return "marker: " + why;
  return "";
}

RosTopicMapping parseTopicMapping(const std::string& text) {
  const ErrorContext where{"", 0, "topic mapping", ""};
  const std::string usage =
      " (expected /topic=label:role[:nonmetric], roles: " + joined(rosTopicRoles()) + ")";
  const size_t equals = text.find('=');
  if (equals == std::string::npos) throw Error(where, "'" + text + "': no '='" + usage);
  if (equals == 0) throw Error(where, "'" + text + "': no topic before '='" + usage);
  RosTopicMapping mapping;
  mapping.topic = text.substr(0, equals);
  std::vector<std::string> parts;
  size_t start = equals + 1;
  while (true) {
    const size_t colon = text.find(':', start);
    parts.push_back(
        text.substr(start, colon == std::string::npos ? std::string::npos : colon - start));
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  if (parts.size() < 2 || parts.size() > 3)
    throw Error(where, "'" + text + "': expected label:role" + usage);
  mapping.label = parts[0];
  mapping.role = parts[1];
  const auto& roles = rosTopicRoles();
  if (std::find(roles.begin(), roles.end(), mapping.role) == roles.end()) {
    throw Error(where, "'" + text + "': unknown role '" + mapping.role + "'" + usage);
  }
  if (parts.size() == 3) {
    if (parts[2] == "nonmetric") {
      mapping.metric = false;
    } else if (parts[2] == "metric") {
      mapping.metric = true;
    } else {
      throw Error(where,
                  "'" + text + "': unknown flag '" + parts[2] + "' (metric, nonmetric)" + usage);
    }
    if (!isTrajectoryRole(mapping.role)) {
      throw Error(
          where, "'" + text + "': '" + parts[2] + "' is for trajectories (odometry, ground_truth)");
    }
  }
  return mapping;
}

// ---------------------------------------------------------------------------
// Mapping YAML

namespace {

struct YamlReader {
  std::string source;

  ErrorContext at(const YAML::Node& node, const std::string& field) const {
    return {source, node.IsDefined() ? static_cast<int>(node.Mark().line) + 1 : 0, field, ""};
  }
  std::string text(const YAML::Node& node, const std::string& field) const {
    if (!node.IsScalar()) throw Error(at(node, field), "expected text");
    return node.Scalar();
  }
  long long integer(const YAML::Node& node, const std::string& field) const {
    const auto value = parseInt(text(node, field));
    if (!value) throw Error(at(node, field), "'" + node.Scalar() + "' is not an integer");
    return *value;
  }
  double number(const YAML::Node& node, const std::string& field) const {
    const auto value = parseDouble(text(node, field));
    if (!value || !std::isfinite(*value)) {
      throw Error(at(node, field), "'" + node.Scalar() + "' is not a finite number");
    }
    return *value;
  }
  bool boolean(const YAML::Node& node, const std::string& field) const {
    const std::string value = text(node, field);
    if (value == "true" || value == "yes") return true;
    if (value == "false" || value == "no") return false;
    throw Error(at(node, field), "expected true or false, got '" + value + "'");
  }
  YAML::Node require(const YAML::Node& parent, const std::string& key,
                     const std::string& field) const {
    const YAML::Node node = parent[key];
    if (!node.IsDefined() || node.IsNull()) throw Error(at(parent, field), "missing");
    return node;
  }
  void requireMap(const YAML::Node& node, const std::string& field) const {
    if (!node.IsMap()) throw Error(at(node, field), "expected a mapping");
  }
  void rejectUnknownKeys(const YAML::Node& node, const std::vector<std::string>& known,
                         const std::string& field) const {
    for (const auto& entry : node) {
      const std::string key = entry.first.Scalar();
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        throw Error(at(entry.first, field.empty() ? key : field + "." + key),
                    "unknown key (known: " + joined(known) + ")");
      }
    }
  }
};

}  // namespace

RosbagImportOptions loadRosbagMapping(const fs::path& yaml) {
  const YamlReader r{yaml.string()};
  YAML::Node root;
  try {
    root = YAML::LoadFile(yaml.string());
  } catch (const YAML::BadFile&) {
    throw Error({yaml.string(), 0, "", ""}, "cannot read the topic mapping file");
  } catch (const YAML::Exception& e) {
    throw Error({yaml.string(), e.mark.line + 1, "", ""}, "not valid YAML: " + e.msg);
  }
  if (!root.IsMap())
    throw Error({yaml.string(), 0, "", ""}, "expected a YAML mapping with 'topics' and 'marker'");
  r.rejectUnknownKeys(root, {"topics", "marker", "calibrations", "use_header_stamp"}, "");

  RosbagImportOptions options;
  const YAML::Node topics = r.require(root, "topics", "topics");
  r.requireMap(topics, "topics");
  for (const auto& entry : topics) {
    RosTopicMapping mapping;
    mapping.topic = r.text(entry.first, "topics");
    const std::string field = "topics." + mapping.topic;
    const YAML::Node node = entry.second;
    r.requireMap(node, field);
    r.rejectUnknownKeys(node, {"label", "role", "metric"}, field);
    mapping.role = r.text(r.require(node, "role", field + ".role"), field + ".role");
    const auto& roles = rosTopicRoles();
    if (std::find(roles.begin(), roles.end(), mapping.role) == roles.end()) {
      throw Error(r.at(node["role"], field + ".role"),
                  "unknown role '" + mapping.role + "' (known: " + joined(roles) + ")");
    }
    if (node["label"]) mapping.label = r.text(node["label"], field + ".label");
    if (node["metric"]) mapping.metric = r.boolean(node["metric"], field + ".metric");
    options.topics.push_back(std::move(mapping));
  }

  const YAML::Node marker = r.require(root, "marker", "marker");
  r.requireMap(marker, "marker");
  r.rejectUnknownKeys(marker, {"dictionary", "id", "size_m"}, "marker");
  options.marker.dictionary =
      r.text(r.require(marker, "dictionary", "marker.dictionary"), "marker.dictionary");
  const long long id = r.integer(r.require(marker, "id", "marker.id"), "marker.id");
  if (id < 0 || id > 1'000'000) throw Error(r.at(marker["id"], "marker.id"), "out of range");
  options.marker.id = static_cast<int>(id);
  options.marker.size_m = r.number(r.require(marker, "size_m", "marker.size_m"), "marker.size_m");
  if (const std::string why = options.marker.check(); !why.empty())
    throw Error(r.at(marker, "marker"), why);

  if (const YAML::Node calibrations = root["calibrations"];
      calibrations && !calibrations.IsNull()) {
    r.requireMap(calibrations, "calibrations");
    for (const auto& entry : calibrations) {
      const std::string label = r.text(entry.first, "calibrations");
      const fs::path file = r.text(entry.second, "calibrations." + label);
      options.calibration_files[label] = file.is_absolute() ? file : yaml.parent_path() / file;
    }
  }
  if (root["use_header_stamp"])
    options.use_header_stamp = r.boolean(root["use_header_stamp"], "use_header_stamp");

  if (const std::string why = options.check(); !why.empty())
    throw Error({yaml.string(), 0, "", ""}, why);
  return options;
}

// ---------------------------------------------------------------------------
// Conversions

namespace {

/// Why a message cannot be converted; the caller adds the bag, topic and message.
struct Problem {
  explicit Problem(std::string why_) : why(std::move(why_)) {}
  std::string why;
};

TimeNs rosTimeToNs(const ros::Time& t) {
  return static_cast<TimeNs>(t.sec) * kNanosecondsPerSecond + static_cast<TimeNs>(t.nsec);
}

/// Width and height from a PNG's IHDR or a JPEG's SOF segment, without decoding.
bool peekImageSize(const std::vector<std::uint8_t>& d, int* width, int* height) {
  const size_t n = d.size();
  auto be16 = [&](size_t i) { return (static_cast<unsigned>(d[i]) << 8) | d[i + 1]; };
  auto be32 = [&](size_t i) {
    return (static_cast<std::uint32_t>(be16(i)) << 16) | static_cast<std::uint32_t>(be16(i + 2));
  };
  static const std::uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (n >= 24 && std::memcmp(d.data(), kPngSignature, 8) == 0 &&
      std::memcmp(d.data() + 12, "IHDR", 4) == 0) {
    const std::uint32_t w = be32(16);
    const std::uint32_t h = be32(20);
    if (w == 0 || h == 0 || w > 1'000'000 || h > 1'000'000) return false;
    *width = static_cast<int>(w);
    *height = static_cast<int>(h);
    return true;
  }
  if (n >= 4 && d[0] == 0xFF && d[1] == 0xD8) {
    size_t i = 2;
    while (i + 1 < n) {
      if (d[i] != 0xFF) return false;
      const std::uint8_t marker = d[i + 1];
      if (marker == 0xFF) {  // fill byte
        ++i;
        continue;
      }
      i += 2;
      if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD8)) continue;  // no length
      if (marker == 0xD9 || marker == 0xDA) return false;  // end, or scan before a frame
      if (i + 2 > n) return false;
      const size_t length = be16(i);
      if (length < 2) return false;
      const bool is_frame =
          marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
      if (is_frame) {
        if (i + 7 > n) return false;  // length(2) precision(1) height(2) width(2)
        *height = static_cast<int>(be16(i + 3));
        *width = static_cast<int>(be16(i + 5));
        return *width > 0 && *height > 0;
      }
      i += length;
    }
  }
  return false;
}

/// ".png" or ".jpg" from the bytes (magic numbers, whatever the format text says); "" for neither.
std::string compressedExtension(const std::vector<std::uint8_t>& d) {
  if (d.size() >= 8 && d[0] == 0x89 && d[1] == 'P' && d[2] == 'N' && d[3] == 'G') return ".png";
  if (d.size() >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF) return ".jpg";
  return "";
}

/// Re-encodes a raw sensor_msgs/Image as PNG. Throws Problem for an encoding
/// or layout it cannot handle.
std::vector<std::uint8_t> encodeRawImageAsPng(const sensor_msgs::Image& image) {
  const std::string& encoding = image.encoding;
  int type = -1;
  int conversion = -1;  // cv::ColorConversionCodes, or -1 for none
  if (encoding == "mono8" || encoding == "8UC1") {
    type = CV_8UC1;
  } else if (encoding == "mono16" || encoding == "16UC1") {
    type = CV_16UC1;
  } else if (encoding == "bgr8" || encoding == "8UC3") {
    type = CV_8UC3;
  } else if (encoding == "rgb8") {
    type = CV_8UC3;
    conversion = cv::COLOR_RGB2BGR;
  } else if (encoding == "bgra8" || encoding == "8UC4") {
    type = CV_8UC4;
    conversion = cv::COLOR_BGRA2BGR;
  } else if (encoding == "rgba8") {
    type = CV_8UC4;
    conversion = cv::COLOR_RGBA2BGR;
  } else if (encoding == "bgr16" || encoding == "16UC3") {
    type = CV_16UC3;
  } else if (encoding == "rgb16") {
    type = CV_16UC3;
    conversion = cv::COLOR_RGB2BGR;
  } else if (encoding == "bayer_rggb8" || encoding == "bayer_rggb16") {
    type = encoding.back() == '8' ? CV_8UC1 : CV_16UC1;
    conversion = cv::COLOR_BayerRGGB2BGR;
  } else if (encoding == "bayer_bggr8" || encoding == "bayer_bggr16") {
    type = encoding.back() == '8' ? CV_8UC1 : CV_16UC1;
    conversion = cv::COLOR_BayerBGGR2BGR;
  } else if (encoding == "bayer_gbrg8" || encoding == "bayer_gbrg16") {
    type = encoding.back() == '8' ? CV_8UC1 : CV_16UC1;
    conversion = cv::COLOR_BayerGBRG2BGR;
  } else if (encoding == "bayer_grbg8" || encoding == "bayer_grbg16") {
    type = encoding.back() == '8' ? CV_8UC1 : CV_16UC1;
    conversion = cv::COLOR_BayerGRBG2BGR;
  } else if (encoding == "yuv422" || encoding == "uyvy") {
    type = CV_8UC2;
    conversion = cv::COLOR_YUV2BGR_UYVY;
  } else if (encoding == "yuv422_yuy2" || encoding == "yuyv") {
    type = CV_8UC2;
    conversion = cv::COLOR_YUV2BGR_YUY2;
  } else {
    throw Problem("unsupported image encoding '" + encoding +
                  "' (supported: mono8, mono16, bgr8, rgb8, bgra8, rgba8, bgr16, rgb16, 8UC1, "
                  "8UC3, 8UC4, 16UC1, 16UC3, "
                  "bayer_{rggb,bggr,gbrg,grbg}{8,16}, yuv422, yuv422_yuy2)");
  }
  const int width = static_cast<int>(image.width);
  const int height = static_cast<int>(image.height);
  if (width <= 0 || height <= 0) throw Problem("empty image (" + sizeText(width, height) + ")");
  const size_t row_bytes = static_cast<size_t>(width) * CV_ELEM_SIZE(type);
  if (image.step < row_bytes) {
    throw Problem("step " + std::to_string(image.step) + " is less than width x pixel size (" +
                  std::to_string(row_bytes) + " bytes)");
  }
  if (image.data.size() < static_cast<size_t>(image.step) * static_cast<size_t>(height)) {
    throw Problem("data holds " + std::to_string(image.data.size()) +
                  " bytes, expected step x height = " +
                  std::to_string(static_cast<size_t>(image.step) * static_cast<size_t>(height)));
  }
  // A view of the message's bytes (not modified, except by a copy below).
  cv::Mat view(height, width, type, const_cast<std::uint8_t*>(image.data.data()), image.step);
  cv::Mat mat = view;
  const bool sixteen_bit = CV_MAT_DEPTH(type) == CV_16U;
  const bool host_big_endian = [] {
    const std::uint16_t probe = 1;
    std::uint8_t first = 0;
    std::memcpy(&first, &probe, 1);
    return first == 0;
  }();
  if (sixteen_bit && (image.is_bigendian != 0) != host_big_endian) {
    mat = view.clone();
    for (int row = 0; row < mat.rows; ++row) {
      auto* p = mat.ptr<std::uint16_t>(row);
      for (int i = 0; i < mat.cols * mat.channels(); ++i)
        p[i] = static_cast<std::uint16_t>((p[i] >> 8) | (p[i] << 8));
    }
  }
  std::vector<std::uint8_t> png;
  try {
    if (conversion >= 0) {
      cv::Mat converted;
      cv::cvtColor(mat, converted, conversion);
      mat = converted;
    }
    if (!cv::imencode(".png", mat, png)) throw Problem("OpenCV could not encode the image as PNG");
  } catch (const cv::Exception& e) {
    throw Problem("OpenCV could not convert the " + encoding + " image: " + e.what());
  }
  return png;
}

/// The camera of a CameraInfo message; nullopt when it holds no calibration
/// (K all zero, as uncalibrated drivers publish). Throws Problem.
std::optional<Camera> cameraFromCameraInfo(const sensor_msgs::CameraInfo& info) {
  const auto& k = info.K;
  if (std::all_of(k.begin(), k.end(), [](double v) { return v == 0.0; })) return std::nullopt;
  if (!std::all_of(k.begin(), k.end(), [](double v) { return std::isfinite(v); }) ||
      !std::all_of(info.D.begin(), info.D.end(), [](double v) { return std::isfinite(v); })) {
    throw Problem("K or D holds a value that is not finite");
  }
  if (k[1] != 0.0) {
    throw Problem("K[0][1] (skew) = " + formatDouble(k[1]) +
                  " is not zero; lookboth camera models have no skew");
  }
  if (k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0) {
    throw Problem("K is not a camera matrix [fx 0 cx; 0 fy cy; 0 0 1]");
  }
  if (info.binning_x > 1 || info.binning_y > 1) {
    throw Problem("binning " + std::to_string(info.binning_x) + "x" +
                  std::to_string(info.binning_y) +
                  " is not supported; give a calibration file for this camera instead");
  }
  const auto& roi = info.roi;
  const bool full_roi =
      (roi.width == 0 && roi.height == 0 && roi.x_offset == 0 && roi.y_offset == 0) ||
      (roi.x_offset == 0 && roi.y_offset == 0 && roi.width == info.width &&
       roi.height == info.height);
  if (!full_roi) {
    throw Problem(
        "a region of interest is not supported; give a calibration file for this camera instead");
  }
  std::vector<double> params = {k[0], k[4], k[2], k[5]};
  const std::vector<double>& d = info.D;
  const std::string& model = info.distortion_model;
  CameraModel camera_model = PinholeModel{};
  auto wrongCount = [&](const std::string& expected) {
    return Problem("distortion_model " + model + " needs " + expected + " coefficients in D, got " +
                   std::to_string(d.size()));
  };
  if (model == "plumb_bob" || (model.empty() && d.empty())) {
    if (d.empty()) {
      camera_model = PinholeModel{};
    } else if (d.size() == 4 || d.size() == 5) {
      camera_model = RadTanModel{};
      params.insert(params.end(), d.begin(), d.end());
      if (d.size() == 4) params.push_back(0.0);
    } else {
      throw wrongCount("5 (k1 k2 p1 p2 k3)");
    }
  } else if (model == "rational_polynomial") {
    if (d.size() != 8) throw wrongCount("8 (k1 k2 p1 p2 k3 k4 k5 k6)");
    camera_model = RationalPolynomialModel{};
    params.insert(params.end(), d.begin(), d.end());
  } else if (model == "equidistant") {
    if (d.size() != 4) throw wrongCount("4 (k1 k2 k3 k4)");
    camera_model = KannalaBrandtModel{};
    params.insert(params.end(), d.begin(), d.end());
  } else {
    throw Problem("unsupported distortion_model '" + model +
                  "' (supported: plumb_bob, rational_polynomial, equidistant)");
  }
  const int width = static_cast<int>(info.width);
  const int height = static_cast<int>(info.height);
  if (const std::string why = Camera::validate(camera_model, width, height, params); !why.empty()) {
    throw Problem(why);
  }
  return Camera(std::move(camera_model), width, height, std::move(params));
}

bool sameCamera(const Camera& a, const Camera& b) {
  return a.modelName() == b.modelName() && a.width() == b.width() && a.height() == b.height() &&
         a.params() == b.params();
}

/// world_from_body of a geometry_msgs/Pose. Throws Problem.
Rigid3d poseFromRos(const geometry_msgs::Pose& pose) {
  const auto& p = pose.position;
  const auto& o = pose.orientation;
  for (double v : {p.x, p.y, p.z, o.x, o.y, o.z, o.w}) {
    if (!std::isfinite(v)) throw Problem("pose holds a value that is not finite");
  }
  Eigen::Quaterniond q(o.w, o.x, o.y, o.z);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > 1e-3) {
    throw Problem("orientation quaternion has norm " + formatFixed(norm, 6) + ", expected 1");
  }
  q.normalize();
  return Rigid3d(q, Eigen::Vector3d(p.x, p.y, p.z));
}

// ---------------------------------------------------------------------------
// Structure check of a ROS bag 2.0 before rosbag_storage reads it.
//
// rosbag_storage trusts the lengths and positions written in a bag: a
// corrupt length makes it read or parse past its buffers and crash, which no
// exception handler can catch. So the bag is first walked here the way
// rosbag_storage will walk it (file header -> index position -> connection
// and chunk info records -> each chunk and the index records after it ->
// the message records the indexes point to), with every length bounded by
// the bytes that are really there. A bag that passes holds nothing that
// makes rosbag_storage read outside what it allocated.

constexpr std::uint8_t kOpMessageData = 0x02;
constexpr std::uint8_t kOpFileHeader = 0x03;
constexpr std::uint8_t kOpIndexData = 0x04;
constexpr std::uint8_t kOpChunk = 0x05;
constexpr std::uint8_t kOpChunkInfo = 0x06;
constexpr std::uint8_t kOpConnection = 0x07;

/// Largest uncompressed chunk accepted: rosbag_storage allocates the size a
/// chunk declares before decompressing it (recorders write chunks of about
/// 768 KiB; one message larger than that makes one chunk as large).
constexpr std::uint32_t kMaxChunkBytes = 1u << 30;

std::uint32_t le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

std::uint64_t le64(const std::uint8_t* p) {
  return static_cast<std::uint64_t>(le32(p)) | static_cast<std::uint64_t>(le32(p + 4)) << 32;
}

/// Bytes that records are read from: the bag file, or one uncompressed chunk.
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual std::uint64_t size() const = 0;
  /// Reads exactly `n` bytes at `offset` (the caller has checked the range).
  virtual void read(std::uint64_t offset, std::size_t n, std::uint8_t* out) = 0;
};

class FileSource final : public ByteSource {
 public:
  FileSource(const fs::path& path, std::uint64_t size)
      : path_(path), in_(path, std::ios::binary), size_(size) {
    if (!in_) throw Error({path.string(), 0, "", ""}, "cannot open for reading");
  }
  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, std::size_t n, std::uint8_t* out) override {
    in_.seekg(static_cast<std::streamoff>(offset));
    in_.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
    if (!in_) {
      throw Error({path_.string(), 0, "", ""},
                  "cannot read " + std::to_string(n) + " bytes at byte " + std::to_string(offset));
    }
  }

 private:
  fs::path path_;
  std::ifstream in_;
  std::uint64_t size_;
};

/// A window [begin, begin + size) of another source.
class WindowSource final : public ByteSource {
 public:
  WindowSource(ByteSource& base, std::uint64_t begin, std::uint64_t size)
      : base_(base), begin_(begin), size_(size) {}
  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, std::size_t n, std::uint8_t* out) override {
    base_.read(begin_ + offset, n, out);
  }

 private:
  ByteSource& base_;
  std::uint64_t begin_, size_;
};

class MemorySource final : public ByteSource {
 public:
  explicit MemorySource(std::vector<std::uint8_t> bytes) : bytes_(std::move(bytes)) {}
  std::uint64_t size() const override { return bytes_.size(); }
  void read(std::uint64_t offset, std::size_t n, std::uint8_t* out) override {
    std::memcpy(out, bytes_.data() + offset, n);
  }

 private:
  std::vector<std::uint8_t> bytes_;
};

/// One record: <header length><header fields><data length><data>.
struct BagRecord {
  std::uint64_t offset = 0;  ///< Of the header length, in its source.
  std::map<std::string, std::string> fields;
  std::uint64_t data_offset = 0;
  std::uint32_t data_length = 0;
  std::uint64_t end() const { return data_offset + data_length; }
};

class BagStructureCheck {
 public:
  explicit BagStructureCheck(const fs::path& path) : path_(path) {}

  void run() {
    std::error_code ec;
    const std::uintmax_t size = fs::file_size(path_, ec);
    if (ec) throw Error({path_.string(), 0, "", ""}, "cannot read its size: " + ec.message());
    FileSource file(path_, size);
    checkVersion(file);
    const BagRecord header = readRecord(file, 13, "the file header record");
    requireOp(header, kOpFileHeader, "the file header record");
    if (const auto it = header.fields.find("encryptor");
        it != header.fields.end() && !it->second.empty()) {
      throw Error(context(), "the bag is encrypted ('" + it->second +
                                 "'); lookboth reads unencrypted bags only (decrypt it first)");
    }
    const std::uint64_t index_position = u64(header, "index_pos", "the file header record");
    if (index_position == 0) return;  // unindexed: rosbag_storage says so before reading on
    const std::uint32_t connection_count = u32(header, "conn_count", "the file header record");
    const std::uint32_t chunk_count = u32(header, "chunk_count", "the file header record");
    if (index_position < header.end() || index_position >= size) {
      throw Error(context(), "the file header record gives the index position " +
                                 std::to_string(index_position) + ", outside the file's " +
                                 std::to_string(header.end()) + ".." + std::to_string(size) +
                                 " bytes (a truncated bag? 'rosbag reindex' may repair it)");
    }

    std::uint64_t offset = index_position;
    for (std::uint32_t i = 0; i < connection_count; ++i) {
      const std::string what = "connection record " + std::to_string(i + 1) + " of " +
                               std::to_string(connection_count) + " (index section)";
      const BagRecord record = readRecord(file, offset, what);
      checkConnection(file, record, what, 0, true);
      offset = record.end();
    }
    std::vector<std::pair<std::uint64_t, std::set<std::uint32_t>>> chunks;  // position, connections
    for (std::uint32_t i = 0; i < chunk_count; ++i) {
      const std::string what =
          "chunk info record " + std::to_string(i + 1) + " of " + std::to_string(chunk_count);
      const BagRecord record = readRecord(file, offset, what);
      chunks.emplace_back(checkChunkInfo(file, record, what));
      offset = record.end();
    }
    for (size_t i = 0; i < chunks.size(); ++i) {
      const auto& [position, connections] = chunks[i];
      const std::string what =
          "chunk " + std::to_string(i + 1) + " of " + std::to_string(chunks.size());
      if (position < header.end() || position >= index_position) {
        corrupt(what, position,
                "its position lies outside the chunk section (bytes " +
                    std::to_string(header.end()) + ".." + std::to_string(index_position) + ")");
      }
      checkChunk(file, position, connections.size(), index_position, what);
    }
  }

 private:
  ErrorContext context() const { return {path_.string(), 0, "", ""}; }

  [[noreturn]] void corrupt(const std::string& what, std::uint64_t offset,
                            const std::string& why) const {
    throw Error(context(),
                "corrupt ROS bag: " + what + " at byte " + std::to_string(offset) + ": " + why);
  }

  void checkVersion(ByteSource& file) const {
    static const std::string kVersion = "#ROSBAG V2.0\n";
    std::string line(kVersion.size(), '\0');
    if (file.size() >= line.size())
      file.read(0, line.size(), reinterpret_cast<std::uint8_t*>(line.data()));
    if (line == kVersion) return;
    if (line.rfind("#ROSBAG V", 0) == 0) {
      throw Error(context(), "a ROS bag of format " + line.substr(9, 3) +
                                 "; lookboth reads format 2.0 ('rosbag fix' converts old bags)");
    }
    throw Error(context(), "not a ROS 1 bag (it does not start with '#ROSBAG V2.0')");
  }

  /// Reads and bounds one record of `source` at `offset`.
  BagRecord readRecord(ByteSource& source, std::uint64_t offset, const std::string& what,
                       std::uint64_t base = 0) const {
    BagRecord record;
    record.offset = offset;
    const std::uint64_t size = source.size();
    auto at = [&](std::uint64_t o) { return base + o; };
    if (offset > size || size - offset < 4) {
      corrupt(what, at(offset),
              "the record's header length lies past the end (" +
                  std::to_string(size - std::min(size, offset)) + " bytes left)");
    }
    std::uint8_t word[8];
    source.read(offset, 4, word);
    const std::uint32_t header_length = le32(word);
    const std::uint64_t left = size - offset - 4;
    if (header_length > left || left - header_length < 4) {
      corrupt(what, at(offset),
              "the header length " + std::to_string(header_length) + " leaves no room for it and " +
                  "the data length in the " + std::to_string(left) + " bytes left");
    }
    std::vector<std::uint8_t> header(header_length);
    if (header_length > 0) source.read(offset + 4, header_length, header.data());
    std::size_t i = 0;
    while (i < header.size()) {
      if (header.size() - i < 4) corrupt(what, at(offset), "a header field's length is cut off");
      const std::uint32_t field_length = le32(header.data() + i);
      i += 4;
      if (field_length > header.size() - i) {
        corrupt(what, at(offset),
                "a header field of " + std::to_string(field_length) + " bytes runs past the " +
                    std::to_string(header_length) + "-byte header");
      }
      const std::string field(reinterpret_cast<const char*>(header.data() + i), field_length);
      i += field_length;
      const size_t equals = field.find('=');
      if (equals == std::string::npos)
        corrupt(what, at(offset), "a header field has no '=' (not a record header)");
      record.fields[field.substr(0, equals)] = field.substr(equals + 1);
    }
    source.read(offset + 4 + header_length, 4, word);
    record.data_length = le32(word);
    record.data_offset = offset + 4 + header_length + 4;
    if (record.data_length > size - record.data_offset) {
      corrupt(what, at(offset),
              "the data length " + std::to_string(record.data_length) + " runs past the end (" +
                  std::to_string(size - record.data_offset) + " bytes left)");
    }
    return record;
  }

  const std::string& field(const BagRecord& record, const std::string& name, std::size_t length,
                           const std::string& what, std::uint64_t base = 0) const {
    const auto it = record.fields.find(name);
    if (it == record.fields.end())
      corrupt(what, base + record.offset, "its header has no '" + name + "' field");
    if (length > 0 && it->second.size() != length) {
      corrupt(what, base + record.offset,
              "its '" + name + "' field has " + std::to_string(it->second.size()) +
                  " bytes, expected " + std::to_string(length));
    }
    return it->second;
  }
  std::uint8_t op(const BagRecord& record, const std::string& what, std::uint64_t base = 0) const {
    return static_cast<std::uint8_t>(field(record, "op", 1, what, base)[0]);
  }
  void requireOp(const BagRecord& record, std::uint8_t expected, const std::string& what,
                 std::uint64_t base = 0) const {
    const std::uint8_t found = op(record, what, base);
    if (found != expected) {
      corrupt(
          what, base + record.offset,
          "record type (op) " + std::to_string(found) + ", expected " + std::to_string(expected));
    }
  }
  std::uint32_t u32(const BagRecord& record, const std::string& name, const std::string& what,
                    std::uint64_t base = 0) const {
    return le32(reinterpret_cast<const std::uint8_t*>(field(record, name, 4, what, base).data()));
  }
  std::uint64_t u64(const BagRecord& record, const std::string& name, const std::string& what,
                    std::uint64_t base = 0) const {
    return le64(reinterpret_cast<const std::uint8_t*>(field(record, name, 8, what, base).data()));
  }

  /// A connection record: its header names the connection, its data is the
  /// connection header (type, md5sum, message definition...).
  /// The connections rosbag_storage knows are those of the index section
  /// (`known`); the copies inside chunks are only checked.
  void checkConnection(ByteSource& source, const BagRecord& record, const std::string& what,
                       std::uint64_t base, bool known) {
    requireOp(record, kOpConnection, what, base);
    const std::uint32_t id = u32(record, "conn", what, base);
    if (known) connections_.insert(id);
    field(record, "topic", 0, what, base);
    // rosbag_storage reads the data length and data as one more header:
    // <length><fields>.
    WindowSource data(source, record.data_offset - 4, std::uint64_t{record.data_length} + 4);
    checkFields(data, what + " (connection header)", base + record.data_offset - 4);
  }

  /// <length><fields> at the start of `source`, bounded by it.
  void checkFields(ByteSource& source, const std::string& what, std::uint64_t base) const {
    std::uint8_t word[4];
    source.read(0, 4, word);
    const std::uint32_t length = le32(word);
    if (length > source.size() - 4) {
      corrupt(what, base,
              "a header of " + std::to_string(length) + " bytes in " +
                  std::to_string(source.size() - 4));
    }
    std::vector<std::uint8_t> bytes(length);
    if (length > 0) source.read(4, length, bytes.data());
    std::size_t i = 0;
    while (i < bytes.size()) {
      if (bytes.size() - i < 4) corrupt(what, base, "a header field's length is cut off");
      const std::uint32_t field_length = le32(bytes.data() + i);
      i += 4;
      if (field_length > bytes.size() - i)
        corrupt(what, base, "a header field runs past the header");
      if (std::memchr(bytes.data() + i, '=', field_length) == nullptr)
        corrupt(what, base, "a header field has no '='");
      i += field_length;
    }
  }

  /// The data of a record that lists `count` entries of `entry_bytes` each
  /// (a chunk info's connections, an index's messages): the count must
  /// account for the data exactly, before anything is read or allocated.
  std::vector<std::uint8_t> readEntries(ByteSource& file, const BagRecord& record,
                                        std::uint32_t count, std::uint64_t entry_bytes,
                                        const char* noun, const std::string& what) {
    if (std::uint64_t{count} * entry_bytes != record.data_length) {
      corrupt(what, record.offset,
              "it lists " + std::to_string(count) + " " + noun + " (" +
                  std::to_string(count * entry_bytes) + " bytes) in " +
                  std::to_string(record.data_length) + " bytes of data");
    }
    std::vector<std::uint8_t> data(record.data_length);
    if (!data.empty()) file.read(record.data_offset, data.size(), data.data());
    return data;
  }

  std::pair<std::uint64_t, std::set<std::uint32_t>> checkChunkInfo(ByteSource& file,
                                                                   const BagRecord& record,
                                                                   const std::string& what) {
    requireOp(record, kOpChunkInfo, what);
    if (const std::uint32_t version = u32(record, "ver", what); version != 1)
      corrupt(what, record.offset,
              "chunk info version " + std::to_string(version) + ", expected 1");
    const std::uint64_t position = u64(record, "chunk_pos", what);
    u64(record, "start_time", what);
    u64(record, "end_time", what);
    const std::uint32_t count = u32(record, "count", what);
    const std::vector<std::uint8_t> data = readEntries(file, record, count, 8, "connections", what);
    std::set<std::uint32_t> connections;
    for (std::uint32_t i = 0; i < count; ++i) {
      const std::uint32_t id = le32(data.data() + 8 * i);
      if (!connections_.count(id))
        corrupt(what, record.offset,
                "it names connection " + std::to_string(id) + ", not in the bag");
      connections.insert(id);
    }
    return {position, connections};
  }

  /// The chunk record at `position`, the `index_records` index records after
  /// it, and the message records they point to.
  void checkChunk(ByteSource& file, std::uint64_t position, std::size_t index_records,
                  std::uint64_t index_position, const std::string& what) {
    const BagRecord chunk = readRecord(file, position, what);
    requireOp(chunk, kOpChunk, what);
    const std::string compression = field(chunk, "compression", 0, what);
    const std::uint32_t size = u32(chunk, "size", what);
    if (chunk.end() > index_position)
      corrupt(what, position, "its data runs into the index section");

    // index data records: connection -> (offset in the uncompressed chunk)
    std::vector<std::pair<std::uint32_t, std::uint32_t>> entries;
    std::uint64_t offset = chunk.end();
    for (std::size_t i = 0; i < index_records; ++i) {
      const std::string index_what = "index record " + std::to_string(i + 1) + " of " + what;
      const BagRecord record = readRecord(file, offset, index_what);
      requireOp(record, kOpIndexData, index_what);
      if (const std::uint32_t version = u32(record, "ver", index_what); version != 1) {
        corrupt(index_what, record.offset,
                "index version " + std::to_string(version) + ", expected 1");
      }
      const std::uint32_t connection = u32(record, "conn", index_what);
      if (!connections_.count(connection)) {
        corrupt(index_what, record.offset,
                "it indexes connection " + std::to_string(connection) + ", not in the bag");
      }
      const std::uint32_t count = u32(record, "count", index_what);
      const std::vector<std::uint8_t> data =
          readEntries(file, record, count, 12, "messages", index_what);
      for (std::uint32_t k = 0; k < count; ++k)
        entries.emplace_back(connection, le32(data.data() + 12 * k + 8));
      offset = record.end();
    }

    // The uncompressed chunk, and its records: message data and connections.
    std::unique_ptr<ByteSource> body;
    if (compression == "none") {
      if (size != chunk.data_length) {
        corrupt(what, position,
                "uncompressed, yet its size field says " + std::to_string(size) + " bytes and " +
                    "its data has " + std::to_string(chunk.data_length));
      }
      body = std::make_unique<WindowSource>(file, chunk.data_offset, chunk.data_length);
    } else if (compression == "bz2" || compression == "lz4") {
      if (size > kMaxChunkBytes) {
        corrupt(what, position,
                "it declares " + std::to_string(size) + " uncompressed bytes (more than " +
                    std::to_string(kMaxChunkBytes) + ")");
      }
      std::vector<std::uint8_t> packed(chunk.data_length);
      if (!packed.empty()) file.read(chunk.data_offset, packed.size(), packed.data());
      std::vector<std::uint8_t> unpacked(size);
      unsigned int produced = size;
      bool ok = false;
      if (compression == "bz2") {
        ok = BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(unpacked.data()), &produced,
                                        reinterpret_cast<char*>(packed.data()),
                                        static_cast<unsigned int>(packed.size()), 0, 0) == BZ_OK;
      } else {
        ok = roslz4_buffToBuffDecompress(
                 reinterpret_cast<char*>(packed.data()), static_cast<unsigned int>(packed.size()),
                 reinterpret_cast<char*>(unpacked.data()), &produced) == ROSLZ4_OK;
      }
      if (!ok) corrupt(what, position, "its " + compression + " data cannot be decompressed");
      if (produced != size) {
        corrupt(what, position,
                "it decompresses to " + std::to_string(produced) + " bytes, not the " +
                    std::to_string(size) + " its size field says");
      }
      body = std::make_unique<MemorySource>(std::move(unpacked));
    } else {
      corrupt(what, position, "unknown compression '" + compression + "'");
    }

    // Offsets in errors: of the file for an uncompressed chunk; of the
    // chunk's uncompressed bytes otherwise (said so in the message).
    const bool plain = compression == "none";
    const std::uint64_t base = plain ? chunk.data_offset : 0;
    const std::string inside = plain ? "a record inside " + what
                                     : "a record of the uncompressed " + what + ", at its offset";
    std::map<std::uint64_t, std::uint32_t> messages;  // offset in the chunk -> connection
    for (std::uint64_t at = 0; at < body->size();) {
      const BagRecord record = readRecord(*body, at, inside, base);
      const std::uint8_t record_op = op(record, inside, base);
      if (record_op == kOpMessageData) {
        const std::uint32_t connection = u32(record, "conn", inside, base);
        u64(record, "time", inside, base);
        messages.emplace(at, connection);
      } else if (record_op == kOpConnection) {
        checkConnection(*body, record, inside, base, false);
      } else {
        corrupt(inside, base + at,
                "record type (op) " + std::to_string(record_op) +
                    " inside a chunk (expected message data or a connection)");
      }
      at = record.end();
    }
    for (const auto& [connection, message_offset] : entries) {
      const auto it = messages.find(message_offset);
      if (it == messages.end()) {
        corrupt(what, position,
                "an index entry of connection " + std::to_string(connection) +
                    " points to chunk offset " + std::to_string(message_offset) +
                    ", where no message record starts");
      }
      if (it->second != connection) {
        corrupt(what, position,
                "the message at chunk offset " + std::to_string(message_offset) +
                    " belongs to connection " + std::to_string(it->second) +
                    ", its index entry says " + std::to_string(connection));
      }
    }
  }

  fs::path path_;
  std::set<std::uint32_t> connections_;
};

// Bounds of a serialized message of the types lookboth converts: every
// string and array length within the message's bytes, so that deserializing
// never allocates more than the message holds.
class MessageBounds {
 public:
  MessageBounds(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  void skip(std::size_t n, const char* what) {
    if (n > size_ - at_) fail(what, n);
    at_ += n;
  }
  std::uint32_t u32(const char* what) {
    if (size_ - at_ < 4) fail(what, 4);
    const std::uint32_t value = le32(data_ + at_);
    at_ += 4;
    return value;
  }
  void array(std::size_t element, const char* what) {
    const std::uint32_t count = u32(what);
    if (count > (size_ - at_) / element) fail(what, std::uint64_t{count} * element);
    at_ += count * element;
  }
  void header() {
    skip(4 + 8, "header.seq/stamp");
    array(1, "header.frame_id");
  }

 private:
  [[noreturn]] void fail(const char* what, std::uint64_t needed) const {
    throw Problem(std::string("the message is corrupt: '") + what + "' needs " +
                  std::to_string(needed) + " bytes at byte " + std::to_string(at_) + " of " +
                  std::to_string(size_));
  }

  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

/// Throws Problem when a length in the serialized `T` runs past its bytes.
template <typename T>
void checkMessageBounds(const std::vector<std::uint8_t>& bytes) {
  MessageBounds m(bytes.data(), bytes.size());
  m.header();
  if constexpr (std::is_same_v<T, sensor_msgs::Image>) {
    m.skip(8, "height/width");
    m.array(1, "encoding");
    m.skip(1 + 4, "is_bigendian/step");
    m.array(1, "data");
  } else if constexpr (std::is_same_v<T, sensor_msgs::CompressedImage>) {
    m.array(1, "format");
    m.array(1, "data");
  } else if constexpr (std::is_same_v<T, sensor_msgs::CameraInfo>) {
    m.skip(8, "height/width");
    m.array(1, "distortion_model");
    m.array(8, "D");
    m.skip(8 * (9 + 9 + 12) + 4 * 2 + 4 * 4 + 1, "K/R/P/binning/roi");
  } else if constexpr (std::is_same_v<T, nav_msgs::Odometry>) {
    m.array(1, "child_frame_id");
    m.skip(8 * (7 + 36 + 6 + 36), "pose/twist");
  } else {
    static_assert(std::is_same_v<T, geometry_msgs::PoseStamped>, "a message type lookboth reads");
    m.skip(8 * 7, "pose");
  }
}

enum class TopicKind { kImage, kCompressedImage, kCameraInfo, kOdometry, kPoseStamped };

struct TopicPlan {
  RosTopicMapping mapping;
  std::string label;
  std::string type;
  TopicKind kind = TopicKind::kImage;
  std::int64_t messages = 0;
  bool info_uncalibrated_warned = false;
  bool info_changed_warned = false;
};

struct CameraState {
  std::string label;
  SensorRole role = SensorRole::kEnvCamera;
  std::optional<Camera> camera;
  std::string calibration_source;  ///< "calibration file x" or "CameraInfo on /t".
  bool from_file = false;
  int first_width = 0;  ///< Size of the first image; 0 before any.
  int first_height = 0;
};

struct StreamState {
  TimeNs last = 0;
  bool any = false;
  std::int64_t duplicates = 0;
  std::int64_t out_of_order = 0;
};

class Importer {
 public:
  Importer(const fs::path& bag_path, const RosbagImportOptions& options, RosbagImportStats* stats)
      : bag_path_(bag_path), options_(options), stats_(stats) {}

  void warn(const std::string& message) {
    stats_->warnings.push_back(message);
    if (options_.on_warning) {
      options_.on_warning(message);
    } else {
      std::cerr << "lookboth: warning: " << message << "\n";
    }
  }

  ErrorContext bagContext(const std::string& subject = "") const {
    return {bag_path_.string(), 0, "", subject};
  }

  std::string bag_name() const { return bag_path_.filename().string(); }

  void open() {
    if (!fs::exists(bag_path_)) throw Error(bagContext(), "no such file");
    const std::string extension = bag_path_.extension().string();
    if (fs::is_directory(bag_path_) || extension == ".db3" || extension == ".mcap") {
      throw Error(
          bagContext(),
          "looks like a ROS 2 bag (a folder, .db3 or .mcap); lookboth reads ROS 1 bags (.bag)");
    }
    BagStructureCheck(bag_path_).run();
    try {
      bag_.open(bag_path_.string(), rosbag::bagmode::Read);
    } catch (const rosbag::BagUnindexedException&) {
      throw Error(bagContext(),
                  "not a usable ROS bag: it has no index (an interrupted recording?); "
                  "run 'rosbag reindex' on it first");
    } catch (const std::exception& e) {
      throw Error(
          bagContext(),
          std::string("cannot read it as a ROS 1 bag (corrupt or truncated?): ") + e.what());
    }
  }

  /// Matches the mapping with the bag's topics; throws for missing topics and unsupported types.
  void plan() {
    std::map<std::string, std::set<std::string>> present;
    {
      rosbag::View all(bag_);
      for (const rosbag::ConnectionInfo* c : all.getConnections())
        present[c->topic].insert(c->datatype);
    }
    auto listPresent = [&] {
      std::string out;
      for (const auto& [topic, types] : present) {
        std::vector<std::string> names(types.begin(), types.end());
        out += (out.empty() ? "" : ", ") + topic + " (" + joined(names) + ")";
      }
      return out.empty() ? std::string("none") : out;
    };
    std::vector<std::string> missing;
    for (const RosTopicMapping& m : options_.topics) {
      if (!present.count(m.topic)) missing.push_back(m.topic);
    }
    if (!missing.empty()) {
      throw Error(bagContext(), std::string(missing.size() == 1 ? "topic " : "topics ") +
                                    joined(missing) + (missing.size() == 1 ? " is" : " are") +
                                    " not in the bag; topics present: " + listPresent());
    }
    std::map<std::string, std::string> image_topic_of_label;
    std::map<std::string, std::string> info_topic_of_label;
    for (const RosTopicMapping& m : options_.topics) {
      const std::set<std::string>& types = present.at(m.topic);
      if (types.size() != 1) {
        throw Error(bagContext(), "topic " + m.topic + " carries several message types (" +
                                      joined({types.begin(), types.end()}) +
                                      "); map one type per topic");
      }
      TopicPlan plan;
      plan.mapping = m;
      plan.label = RosbagImportOptions::effectiveLabel(m);
      plan.type = *types.begin();
      if (plan.type == kImageType) {
        plan.kind = TopicKind::kImage;
      } else if (plan.type == kCompressedImageType) {
        plan.kind = TopicKind::kCompressedImage;
      } else if (plan.type == kCameraInfoType) {
        plan.kind = TopicKind::kCameraInfo;
      } else if (plan.type == kOdometryType) {
        plan.kind = TopicKind::kOdometry;
      } else if (plan.type == kPoseStampedType) {
        plan.kind = TopicKind::kPoseStamped;
      } else {
        throw Error(bagContext(), "topic " + m.topic + " has the unsupported message type " +
                                      plan.type + " (supported: " + kImageType + ", " +
                                      kCompressedImageType + ", " + kCameraInfoType + ", " +
                                      kOdometryType + ", " + kPoseStampedType + ")");
      }
      const bool camera_type = plan.kind == TopicKind::kImage ||
                               plan.kind == TopicKind::kCompressedImage ||
                               plan.kind == TopicKind::kCameraInfo;
      if (camera_type && !isCameraRole(m.role)) {
        throw Error(bagContext(), "topic " + m.topic + " (" + plan.type + ") is mapped with role " +
                                      m.role +
                                      "; a camera topic takes the role fisheye or env_camera");
      }
      if (!camera_type && !isTrajectoryRole(m.role)) {
        throw Error(bagContext(), "topic " + m.topic + " (" + plan.type + ") is mapped with role " +
                                      m.role +
                                      "; a pose topic takes the role odometry or ground_truth");
      }
      if (plan.kind == TopicKind::kImage || plan.kind == TopicKind::kCompressedImage) {
        const auto [it, inserted] = image_topic_of_label.emplace(plan.label, m.topic);
        if (!inserted) {
          throw Error(bagContext(), "topics " + it->second + " and " + m.topic +
                                        " both carry images of camera '" + plan.label +
                                        "'; map one image topic per camera");
        }
      }
      if (plan.kind == TopicKind::kCameraInfo) {
        const auto [it, inserted] = info_topic_of_label.emplace(plan.label, m.topic);
        if (!inserted) {
          throw Error(bagContext(), "topics " + it->second + " and " + m.topic +
                                        " both carry the camera info of camera '" + plan.label +
                                        "'");
        }
      }
      plans_.emplace(m.topic, std::move(plan));
    }
  }

  Manifest initialManifest(const std::string& name) {
    Manifest manifest;
    manifest.name = name;
    manifest.marker = options_.marker;
    // Cameras: the fisheye first, then environment cameras in mapping order.
    for (int pass = 0; pass < 2; ++pass) {
      for (const RosTopicMapping& m : options_.topics) {
        if (!isCameraRole(m.role) || (m.role == "fisheye") != (pass == 0)) continue;
        const std::string label = RosbagImportOptions::effectiveLabel(m);
        if (cameras_.count(label)) continue;
        CameraState& state = cameras_[label];
        state.label = label;
        state.role = m.role == "fisheye" ? SensorRole::kFisheye : SensorRole::kEnvCamera;
        camera_order_.push_back(label);
        if (const auto it = options_.calibration_files.find(label);
            it != options_.calibration_files.end()) {
          try {
            state.camera = loadCamera(it->second);
          } catch (const Error& e) {
            throw Error(ErrorContext{"", 0, "", label}, e.what());
          }
          state.from_file = true;
          state.calibration_source = "calibration file " + it->second.string();
        }
      }
    }
    for (const RosTopicMapping& m : options_.topics) {
      if (!isTrajectoryRole(m.role)) continue;
      const TopicPlan& plan = plans_.at(m.topic);
      TrajectoryInfo info;
      info.label = plan.label;
      info.metric = m.metric;
      info.description = "ROS topic " + m.topic + " (" + plan.type + ")";
      manifest.trajectories.push_back(info);
    }
    return manifest;
  }

  void fillCameras(Manifest* manifest) const {
    manifest->cameras.clear();
    for (const std::string& label : camera_order_) {
      const CameraState& state = cameras_.at(label);
      manifest->cameras.push_back(CameraSensor{state.label, state.role, state.camera});
    }
  }

  /// Sets each camera's calibration from the first usable message of its
  /// CameraInfo topic (unless a calibration file is given), before any image
  /// is converted: writers need the calibrations up front, and images are
  /// checked against them.
  void readFirstCalibrations() {
    for (const auto& [topic, plan] : plans_) {
      if (plan.kind != TopicKind::kCameraInfo) continue;
      CameraState& state = cameras_.at(plan.label);
      if (state.from_file) continue;
      TopicPlan probe = plan;
      try {
        rosbag::View view(bag_, rosbag::TopicQuery(topic));
        for (const rosbag::MessageInstance& message : view) {
          ++probe.messages;
          const auto msg = instantiate<sensor_msgs::CameraInfo>(message, probe);
          if (std::optional<Camera> camera = convertInfo(probe, *msg)) {
            state.camera = std::move(camera);
            state.calibration_source = "CameraInfo on " + topic;
            break;
          }
        }
      } catch (const Error&) {
        throw;
      } catch (const std::exception& e) {
        throw Error(bagContext(), "cannot read the bag (topic " + topic + ", message " +
                                      std::to_string(probe.messages + 1) + "): " + e.what());
      }
    }
  }

  /// Cameras with no calibration at all (no usable CameraInfo, no file).
  std::vector<std::string> uncalibratedCameras() const {
    std::vector<std::string> labels;
    for (const std::string& label : camera_order_) {
      if (!cameras_.at(label).camera) labels.push_back(label);
    }
    return labels;
  }

  /// Streams the mapped topics into the writer.
  void run(DatasetWriter& writer, const ProgressReporter& progress) {
    std::vector<std::string> topics;
    for (const RosTopicMapping& m : options_.topics) topics.push_back(m.topic);
    std::int64_t done = 0;
    std::int64_t total = 0;
    std::string topic;
    try {
      rosbag::View view(bag_, rosbag::TopicQuery(topics));
      total = view.size();
      progress.report("import", 0, total, bag_name());
      for (const rosbag::MessageInstance& message : view) {
        progress.checkStop();
        topic = message.getTopic();
        TopicPlan& plan = plans_.at(topic);
        ++plan.messages;
        ++stats_->messages_per_topic[topic];
        handle(message, plan, writer);
        ++done;
        progress.report("import", done, total);
      }
    } catch (const Error&) {
      throw;
    } catch (const StopRequested&) {
      throw;
    } catch (const std::exception& e) {
      const std::string where = topic.empty() ? std::string() : " (last topic read: " + topic + ")";
      throw Error(bagContext(), "cannot read the bag after " + std::to_string(done) + " of " +
                                    std::to_string(total) + " messages" + where + ": " + e.what());
    }
  }

  void finishChecks() {
    for (const RosTopicMapping& m : options_.topics) {
      const TopicPlan& plan = plans_.at(m.topic);
      if (plan.messages == 0) warn("topic " + m.topic + " has no message in " + bag_name());
    }
    for (const auto& [key, stream] : streams_) {
      if (stream.duplicates > 0) {
        warn(key + ": " + std::to_string(stream.duplicates) +
             " message(s) repeat the previous timestamp; dropped");
      }
      if (stream.out_of_order > 0) {
        warn(key + ": " + std::to_string(stream.out_of_order) +
             " message(s) have a timestamp earlier than the previous one; kept in bag order");
      }
    }
    for (const std::string& label : camera_order_) {
      const CameraState& state = cameras_.at(label);
      if (!state.camera) {
        warn("camera '" + label +
             "' has no calibration (no usable CameraInfo and no calibration file)");
      }
    }
  }

 private:
  /// Throws an error naming the bag, the topic, the message (counted per topic) and the label.
  [[noreturn]] void fail(const TopicPlan& plan, const std::string& why) const {
    throw Error(bagContext(plan.label), "topic " + plan.mapping.topic + ", message " +
                                            std::to_string(plan.messages) + ": " + why);
  }

  TimeNs messageTime(const rosbag::MessageInstance& message, const TopicPlan& plan,
                     const ros::Time& stamp) const {
    if (!options_.use_header_stamp) return rosTimeToNs(message.getTime());
    if (stamp.sec == 0 && stamp.nsec == 0) {
      fail(
          plan,
          "header.stamp is zero (the publisher does not stamp its messages); import with the bag's "
          "receive times instead (use_header_stamp: false)");
    }
    return rosTimeToNs(stamp);
  }

  /// The message, deserialized once its lengths are known to stay within its bytes.
  template <typename T>
  boost::shared_ptr<T> instantiate(const rosbag::MessageInstance& message,
                                   const TopicPlan& plan) const {
    if (!message.isType<T>()) {
      fail(plan, "the message definition of " + plan.type + " in the bag (md5sum " +
                     message.getMD5Sum() + ") differs from the one lookboth knows (" +
                     ros::message_traits::MD5Sum<T>::value() + ")");
    }
    std::vector<std::uint8_t> bytes(message.size());
    ros::serialization::OStream out(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
    message.write(out);
    try {
      checkMessageBounds<T>(bytes);
    } catch (const Problem& problem) {
      fail(plan, problem.why);
    }
    auto msg = boost::make_shared<T>();
    ros::serialization::IStream in(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
    ros::serialization::deserialize(in, *msg);
    return msg;
  }

  /// False for a record to drop (its stream already has that timestamp).
  bool acceptTime(const std::string& kind, const std::string& label, TimeNs t) {
    StreamState& stream = streams_[kind + " of '" + label + "'"];
    if (stream.any) {
      if (t == stream.last) {
        ++stream.duplicates;
        return false;
      }
      if (t < stream.last) ++stream.out_of_order;
    }
    stream.any = true;
    stream.last = t;
    return true;
  }

  std::optional<Camera> convertInfo(const TopicPlan& plan,
                                    const sensor_msgs::CameraInfo& info) const {
    try {
      return cameraFromCameraInfo(info);
    } catch (const Problem& problem) {
      fail(plan, problem.why);
    } catch (const Error& e) {
      fail(plan, e.message());
    }
  }

  void checkImageSize(const TopicPlan& plan, int width, int height) {
    CameraState& state = cameras_.at(plan.label);
    if (state.camera && (state.camera->width() != width || state.camera->height() != height)) {
      fail(plan, "image size " + sizeText(width, height) + " differs from the calibration's " +
                     sizeText(state.camera->width(), state.camera->height()) + " (" +
                     state.calibration_source + ")");
    }
    if (state.first_width == 0) {
      state.first_width = width;
      state.first_height = height;
    } else if (state.first_width != width || state.first_height != height) {
      fail(plan, "image size " + sizeText(width, height) + " differs from the earlier images' " +
                     sizeText(state.first_width, state.first_height));
    }
  }

  void handle(const rosbag::MessageInstance& message, TopicPlan& plan, DatasetWriter& writer) {
    switch (plan.kind) {
      case TopicKind::kImage: {
        const auto msg = instantiate<sensor_msgs::Image>(message, plan);
        const TimeNs t = messageTime(message, plan, msg->header.stamp);
        checkImageSize(plan, static_cast<int>(msg->width), static_cast<int>(msg->height));
        if (!acceptTime("images", plan.label, t)) return;
        ImageFrame frame;
        frame.t = t;
        frame.sensor = plan.label;
        try {
          frame.encoded =
              std::make_shared<const std::vector<std::uint8_t>>(encodeRawImageAsPng(*msg));
        } catch (const Problem& problem) {
          fail(plan, problem.why);
        }
        frame.extension = ".png";
        write(writer, std::move(frame));
        return;
      }
      case TopicKind::kCompressedImage: {
        const auto msg = instantiate<sensor_msgs::CompressedImage>(message, plan);
        const TimeNs t = messageTime(message, plan, msg->header.stamp);
        if (msg->format.find("compressedDepth") != std::string::npos) {
          fail(plan, "compressed depth images (format '" + msg->format + "') are not supported");
        }
        const std::string extension = compressedExtension(msg->data);
        if (extension.empty()) {
          fail(plan, "the image bytes (format '" + msg->format + "') are neither PNG nor JPEG");
        }
        int width = 0;
        int height = 0;
        if (!peekImageSize(msg->data, &width, &height)) {
          const cv::Mat decoded = cv::imdecode(msg->data, cv::IMREAD_UNCHANGED);
          if (decoded.empty())
            fail(plan, "the image bytes (format '" + msg->format + "') cannot be decoded");
          width = decoded.cols;
          height = decoded.rows;
        }
        checkImageSize(plan, width, height);
        if (!acceptTime("images", plan.label, t)) return;
        ImageFrame frame;
        frame.t = t;
        frame.sensor = plan.label;
        frame.encoded = std::make_shared<const std::vector<std::uint8_t>>(std::move(msg->data));
        frame.extension = extension;
        write(writer, std::move(frame));
        return;
      }
      case TopicKind::kCameraInfo: {
        const auto msg = instantiate<sensor_msgs::CameraInfo>(message, plan);
        const std::optional<Camera> camera = convertInfo(plan, *msg);
        const CameraState& state = cameras_.at(plan.label);
        if (!camera) {
          if (!plan.info_uncalibrated_warned && !state.from_file) {
            warn("topic " + plan.mapping.topic +
                 ": CameraInfo holds no calibration (K is all zero); ignored");
          }
          plan.info_uncalibrated_warned = true;
          return;
        }
        // readFirstCalibrations() set the calibration from the first usable message.
        if (!plan.info_changed_warned && state.camera && !sameCamera(*camera, *state.camera)) {
          if (state.from_file) {
            warn("topic " + plan.mapping.topic + ": CameraInfo (" + camera->description() +
                 ") differs from the " + state.calibration_source + " (" +
                 state.camera->description() + "); using the file");
          } else {
            warn("topic " + plan.mapping.topic +
                 ": CameraInfo changes during the recording (message " +
                 std::to_string(plan.messages) + ": " + camera->description() +
                 "); keeping the first one (" + state.camera->description() + ")");
          }
          plan.info_changed_warned = true;
        }
        return;
      }
      case TopicKind::kOdometry: {
        const auto msg = instantiate<nav_msgs::Odometry>(message, plan);
        writePose(message, plan, writer, msg->header.stamp, msg->pose.pose);
        return;
      }
      case TopicKind::kPoseStamped: {
        const auto msg = instantiate<geometry_msgs::PoseStamped>(message, plan);
        writePose(message, plan, writer, msg->header.stamp, msg->pose);
        return;
      }
    }
  }

  void writePose(const rosbag::MessageInstance& message, const TopicPlan& plan,
                 DatasetWriter& writer, const ros::Time& stamp, const geometry_msgs::Pose& pose) {
    const TimeNs t = messageTime(message, plan, stamp);
    PoseSample sample;
    sample.t = t;
    sample.label = plan.label;
    try {
      sample.world_from_body = poseFromRos(pose);
    } catch (const Problem& problem) {
      fail(plan, problem.why);
    }
    if (!acceptTime("poses", plan.label, t)) return;
    write(writer, std::move(sample));
  }

  void write(DatasetWriter& writer, Record record) {
    writer.write(record);
    ++stats_->records;
  }

  fs::path bag_path_;
  const RosbagImportOptions& options_;
  RosbagImportStats* stats_;
  rosbag::Bag bag_;
  std::map<std::string, TopicPlan> plans_;
  std::map<std::string, CameraState> cameras_;
  std::vector<std::string> camera_order_;
  std::map<std::string, StreamState> streams_;
};

std::string datasetName(const fs::path& out) {
  fs::path normal = out.lexically_normal();
  if (normal.filename().empty()) normal = normal.parent_path();
  return normal.stem().string();
}

}  // namespace

RosbagImportStats importRosbag(const fs::path& bag, const fs::path& out, DatasetKind kind,
                               const RosbagImportOptions& options,
                               const DatasetWriteOptions& write_options,
                               const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) {
    throw Error("ROS bag import options: " + why);
  }
  std::error_code ec;
  if (fs::exists(out, ec) && fs::equivalent(out, bag, ec)) {
    throw Error({out.string(), 0, "", ""},
                "the output is the input bag; choose another output path");
  }
  RosbagImportStats stats;
  Importer importer(bag, options, &stats);
  importer.open();
  importer.plan();
  Manifest manifest = importer.initialManifest(datasetName(out));
  importer.readFirstCalibrations();
  if (kind == DatasetKind::kFolder) {
    if (const std::vector<std::string> missing = importer.uncalibratedCameras(); !missing.empty()) {
      throw Error({out.string(), 0, "", ""},
                  "the dataset folder format needs a calibration for every camera; " +
                      joined(missing) + (missing.size() == 1 ? " has" : " have") +
                      " none (map a CameraInfo topic to the camera's label, give a calibration "
                      "file, or write a "
                      "rawlog dataset)");
    }
  }
  importer.fillCameras(&manifest);
  std::unique_ptr<DatasetWriter> writer = DatasetWriter::create(out, kind, manifest, write_options);
  importer.run(*writer, progress);
  importer.finishChecks();
  writer->finish(manifest);
  return stats;
}

}  // namespace lookboth
