#include "lookboth/dataset/rosbag_import.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iostream>
#include <map>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <set>

#include "bag_source.h"
#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth {

namespace fs = std::filesystem;

namespace {

using bag::MessageKind;

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
    if (!m.child_frame.empty() && !isTrajectoryRole(m.role)) {
      return "'" + field +
             ".child_frame': a transform topic gives a trajectory (role odometry "
             "or ground_truth), not role " +
             m.role;
    }
    if (!m.parent_frame.empty() && m.child_frame.empty()) {
      return "'" + field + ".parent_frame': given without child_frame";
    }
    if (!m.body_frame.empty() && !isTrajectoryRole(m.role)) {
      return "'" + field +
             ".body_frame': for trajectories (role odometry or ground_truth), not "
             "role " +
             m.role;
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
      " (expected /topic=label:role[:nonmetric][:child=<frame>[:parent=<frame>]][:body=<frame>], "
      "roles: " +
      joined(rosTopicRoles()) + ")";
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
  if (parts.size() < 2) throw Error(where, "'" + text + "': expected label:role" + usage);
  mapping.label = parts[0];
  mapping.role = parts[1];
  const auto& roles = rosTopicRoles();
  if (std::find(roles.begin(), roles.end(), mapping.role) == roles.end()) {
    throw Error(where, "'" + text + "': unknown role '" + mapping.role + "'" + usage);
  }
  for (size_t i = 2; i < parts.size(); ++i) {
    const std::string& flag = parts[i];
    if (flag == "nonmetric" || flag == "metric") {
      mapping.metric = flag == "metric";
    } else if (flag.rfind("child=", 0) == 0 && flag.size() > 6) {
      mapping.child_frame = flag.substr(6);
    } else if (flag.rfind("parent=", 0) == 0 && flag.size() > 7) {
      mapping.parent_frame = flag.substr(7);
    } else if (flag.rfind("body=", 0) == 0 && flag.size() > 5) {
      mapping.body_frame = flag.substr(5);
    } else {
      throw Error(where, "'" + text + "': unknown flag '" + flag +
                             "' (metric, nonmetric, child=<frame>, parent=<frame>, body=<frame>)" +
                             usage);
    }
    if (!isTrajectoryRole(mapping.role)) {
      throw Error(where,
                  "'" + text + "': '" + flag + "' is for trajectories (odometry, ground_truth)");
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
    r.rejectUnknownKeys(
        node, {"label", "role", "metric", "child_frame", "parent_frame", "body_frame"}, field);
    mapping.role = r.text(r.require(node, "role", field + ".role"), field + ".role");
    const auto& roles = rosTopicRoles();
    if (std::find(roles.begin(), roles.end(), mapping.role) == roles.end()) {
      throw Error(r.at(node["role"], field + ".role"),
                  "unknown role '" + mapping.role + "' (known: " + joined(roles) + ")");
    }
    if (node["label"]) mapping.label = r.text(node["label"], field + ".label");
    if (node["metric"]) mapping.metric = r.boolean(node["metric"], field + ".metric");
    if (node["child_frame"])
      mapping.child_frame = r.text(node["child_frame"], field + ".child_frame");
    if (node["parent_frame"])
      mapping.parent_frame = r.text(node["parent_frame"], field + ".parent_frame");
    if (node["body_frame"]) mapping.body_frame = r.text(node["body_frame"], field + ".body_frame");
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

using bag::Problem;
using bag::rosTimeToNs;

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

/// A transform's parent_from_child as a pose (of the child in the parent).
geometry_msgs::Pose poseOfTransform(const geometry_msgs::TransformStamped& transform) {
  geometry_msgs::Pose pose;
  pose.position.x = transform.transform.translation.x;
  pose.position.y = transform.transform.translation.y;
  pose.position.z = transform.transform.translation.z;
  pose.orientation = transform.transform.rotation;
  return pose;
}

/// The static transforms of /tf_static (the robot's mounts): each frame's
/// parent and parent_from_child, and any two connected frames' a_from_b.
class StaticFrames {
 public:
  void add(const std::string& parent, const std::string& child, const Rigid3d& parent_from_child) {
    parents_[child] = {parent, parent_from_child};
  }
  bool empty() const { return parents_.empty(); }

  /// a_from_b through the tree; nullopt when the two are not connected.
  std::optional<Rigid3d> between(const std::string& a, const std::string& b) const {
    const auto [root_of_a, root_from_a] = toRoot(a);
    const auto [root_of_b, root_from_b] = toRoot(b);
    if (root_of_a != root_of_b) return std::nullopt;
    return root_from_a.inverse() * root_from_b;
  }

  /// "base_link -> mast, mast -> fisheye_link" for messages.
  std::string describe() const {
    std::vector<std::string> edges;
    for (const auto& [child, parent] : parents_) edges.push_back(parent.first + " -> " + child);
    std::sort(edges.begin(), edges.end());
    return edges.empty() ? std::string("none") : joined(edges);
  }

 private:
  std::pair<std::string, Rigid3d> toRoot(std::string frame) const {
    Rigid3d root_from_frame = Rigid3d::Identity();
    // Bounded: a cycle in a damaged /tf_static must not hang the import.
    for (size_t depth = 0; depth <= parents_.size(); ++depth) {
      const auto it = parents_.find(frame);
      if (it == parents_.end()) break;
      root_from_frame = it->second.second * root_from_frame;
      frame = it->second.first;
    }
    return {frame, root_from_frame};
  }

  std::map<std::string, std::pair<std::string, Rigid3d>> parents_;
};

struct TopicPlan {
  RosTopicMapping mapping;
  std::string label;
  std::string type;
  MessageKind kind = MessageKind::kImage;
  std::int64_t messages = 0;
  bool info_uncalibrated_warned = false;
  bool info_changed_warned = false;
  bool parent_mismatch_warned = false;
  /// body_frame: child_from_body by the messages' child frame.
  std::map<std::string, Rigid3d> child_from_body;
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

  std::string bag_name() const {
    fs::path normal = bag_path_.lexically_normal();
    if (normal.filename().empty()) normal = normal.parent_path();
    return normal.filename().string();
  }

  /// A folder, .mcap or .db3 is a ROS 2 bag; anything else is read as ROS 1.
  void open() {
    if (!fs::exists(bag_path_)) throw Error(bagContext(), "no such file");
    source_ = bag::looksLikeRos2Bag(bag_path_) ? bag::openRos2Bag(bag_path_)
                                               : bag::openRos1Bag(bag_path_);
    for (const std::string& note : source_->notes()) warn(note);
  }

  /// A transform topic needs the frame it is to follow; other topics have no frames.
  void checkTransformMapping(const TopicPlan& plan) const {
    const bool transforms = plan.kind == MessageKind::kTransforms;
    if (transforms && plan.mapping.child_frame.empty()) {
      throw Error(bagContext(), "topic " + plan.mapping.topic + " (" + plan.type +
                                    ") holds transforms between frames: name the frame to follow "
                                    "(child_frame in the mapping file, or :child=<frame>)");
    }
    if (!transforms && !plan.mapping.child_frame.empty()) {
      throw Error(bagContext(), "topic " + plan.mapping.topic + " (" + plan.type +
                                    ") is not a transform topic; child_frame is for " +
                                    "tf2_msgs/TFMessage topics");
    }
  }

  /// Matches the mapping with the bag's topics; throws for missing topics and unsupported types.
  void plan() {
    const std::map<std::string, std::set<std::string>> present = source_->topicTypes();
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
      const std::optional<MessageKind> kind = bag::kindOfType(plan.type);
      if (!kind) {
        throw Error(bagContext(),
                    "topic " + m.topic + " has the unsupported message type " + plan.type +
                        " (supported: " + joined(bag::supportedTypeNames(source_->ros2())) + ")");
      }
      plan.kind = *kind;
      checkTransformMapping(plan);
      if (!m.body_frame.empty() && plan.kind != MessageKind::kOdometry &&
          plan.kind != MessageKind::kTransforms) {
        throw Error(bagContext(), "topic " + m.topic + " (" + plan.type +
                                      ") does not name the frame of its poses; body_frame needs "
                                      "nav_msgs/Odometry (child_frame_id) or a /tf topic");
      }
      const bool camera_type = plan.kind == MessageKind::kImage ||
                               plan.kind == MessageKind::kCompressedImage ||
                               plan.kind == MessageKind::kCameraInfo;
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
      if (plan.kind == MessageKind::kImage || plan.kind == MessageKind::kCompressedImage) {
        const auto [it, inserted] = image_topic_of_label.emplace(plan.label, m.topic);
        if (!inserted) {
          throw Error(bagContext(), "topics " + it->second + " and " + m.topic +
                                        " both carry images of camera '" + plan.label +
                                        "'; map one image topic per camera");
        }
      }
      if (plan.kind == MessageKind::kCameraInfo) {
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
    for (const auto& entry : plans_) {
      // Named, not a structured binding: C++17 lambdas cannot capture those.
      const std::string& topic = entry.first;
      const TopicPlan& plan = entry.second;
      if (plan.kind != MessageKind::kCameraInfo) continue;
      CameraState& state = cameras_.at(plan.label);
      if (state.from_file) continue;
      TopicPlan probe = plan;
      readTopic(probe, [&](const bag::BagMessage& message) {
        const auto msg = decode(probe, [&] { return message.cameraInfo(); });
        if (std::optional<Camera> camera = convertInfo(probe, msg)) {
          state.camera = std::move(camera);
          state.calibration_source = "CameraInfo on " + topic;
          return false;
        }
        return true;
      });
    }
  }

  /// Reads `probe`'s topic ahead of the import, message by message while
  /// `visit` returns true; a reader's failure becomes an error naming the message.
  template <typename Visit>
  void readTopic(TopicPlan& probe, Visit&& visit) {
    const std::string& topic = probe.mapping.topic;
    try {
      source_->forEach({topic}, [&](const bag::BagMessage& message) {
        ++probe.messages;
        return visit(message);
      });
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw Error(bagContext(), "cannot read the bag (topic " + topic + ", message " +
                                    std::to_string(probe.messages + 1) + "): " + e.what());
    }
  }

  /// The mounts of /tf_static, read first when a trajectory is to be carried
  /// to another frame (body_frame): they are published once, at the start.
  void readStaticTransforms() {
    const bool needed = std::any_of(plans_.begin(), plans_.end(), [](const auto& entry) {
      return !entry.second.mapping.body_frame.empty();
    });
    if (!needed) return;
    const std::string topic = "/tf_static";
    if (!source_->topicTypes().count(topic)) {
      throw Error(bagContext(), "body_frame needs the robot's mounts from " + topic +
                                    ", which the bag does not have");
    }
    TopicPlan probe;
    probe.mapping.topic = topic;
    readTopic(probe, [&](const bag::BagMessage& message) {
      for (const geometry_msgs::TransformStamped& transform :
           decode(probe, [&] { return message.transforms(); })) {
        try {
          static_frames_.add(transform.header.frame_id, transform.child_frame_id,
                             poseFromRos(poseOfTransform(transform)));
        } catch (const Problem& problem) {
          fail(probe, problem.why);
        }
      }
      return true;
    });
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
      total = std::max<std::int64_t>(source_->count(topics), 0);  // 0: unknown
      progress.report("import", 0, total, bag_name());
      source_->forEach(topics, [&](const bag::BagMessage& message) {
        progress.checkStop();
        topic = message.topic();
        TopicPlan& plan = plans_.at(topic);
        ++plan.messages;
        ++stats_->messages_per_topic[topic];
        handle(message, plan, writer);
        ++done;
        progress.report("import", done, total);
        return true;
      });
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

  TimeNs messageTime(const bag::BagMessage& message, const TopicPlan& plan,
                     const ros::Time& stamp) const {
    if (!options_.use_header_stamp) return message.receiveTime();
    if (stamp.sec == 0 && stamp.nsec == 0) {
      fail(
          plan,
          "header.stamp is zero (the publisher does not stamp its messages); import with the bag's "
          "receive times instead (use_header_stamp: false)");
    }
    return rosTimeToNs(stamp);
  }

  /// The message `decoder` returns, or an error naming the bag, topic and message.
  template <typename Decode>
  auto decode(const TopicPlan& plan, Decode&& decoder) const -> decltype(decoder()) {
    try {
      return decoder();
    } catch (const Problem& problem) {
      fail(plan, problem.why);
    }
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

  void handle(const bag::BagMessage& message, TopicPlan& plan, DatasetWriter& writer) {
    switch (plan.kind) {
      case MessageKind::kImage:
        return handleImage(message, plan, writer);
      case MessageKind::kCompressedImage:
        return handleCompressedImage(message, plan, writer);
      case MessageKind::kCameraInfo:
        return handleCameraInfo(message, plan);
      case MessageKind::kOdometry: {
        const auto msg = decode(plan, [&] { return message.odometry(); });
        return writePose(message, plan, writer, msg.header.stamp, msg.pose.pose,
                         msg.child_frame_id);
      }
      case MessageKind::kPoseStamped: {
        const auto msg = decode(plan, [&] { return message.poseStamped(); });
        return writePose(message, plan, writer, msg.header.stamp, msg.pose);
      }
      case MessageKind::kPoseWithCovarianceStamped: {
        const auto msg = decode(plan, [&] { return message.poseWithCovarianceStamped(); });
        return writePose(message, plan, writer, msg.header.stamp, msg.pose.pose);
      }
      case MessageKind::kTransforms:
        return handleTransforms(message, plan, writer);
    }
  }

  void handleImage(const bag::BagMessage& message, TopicPlan& plan, DatasetWriter& writer) {
    const auto msg = decode(plan, [&] { return message.image(); });
    const TimeNs t = messageTime(message, plan, msg.header.stamp);
    checkImageSize(plan, static_cast<int>(msg.width), static_cast<int>(msg.height));
    if (!acceptTime("images", plan.label, t)) return;
    ImageFrame frame;
    frame.t = t;
    frame.sensor = plan.label;
    try {
      frame.encoded = std::make_shared<const std::vector<std::uint8_t>>(encodeRawImageAsPng(msg));
    } catch (const Problem& problem) {
      fail(plan, problem.why);
    }
    frame.extension = ".png";
    write(writer, std::move(frame));
  }

  void handleCompressedImage(const bag::BagMessage& message, TopicPlan& plan,
                             DatasetWriter& writer) {
    auto msg = decode(plan, [&] { return message.compressedImage(); });
    const TimeNs t = messageTime(message, plan, msg.header.stamp);
    if (msg.format.find("compressedDepth") != std::string::npos) {
      fail(plan, "compressed depth images (format '" + msg.format + "') are not supported");
    }
    const std::string extension = compressedExtension(msg.data);
    if (extension.empty()) {
      fail(plan, "the image bytes (format '" + msg.format + "') are neither PNG nor JPEG");
    }
    int width = 0;
    int height = 0;
    if (!peekImageSize(msg.data, &width, &height)) {
      const cv::Mat decoded = cv::imdecode(msg.data, cv::IMREAD_UNCHANGED);
      if (decoded.empty())
        fail(plan, "the image bytes (format '" + msg.format + "') cannot be decoded");
      width = decoded.cols;
      height = decoded.rows;
    }
    checkImageSize(plan, width, height);
    if (!acceptTime("images", plan.label, t)) return;
    ImageFrame frame;
    frame.t = t;
    frame.sensor = plan.label;
    frame.encoded = std::make_shared<const std::vector<std::uint8_t>>(std::move(msg.data));
    frame.extension = extension;
    write(writer, std::move(frame));
  }

  void handleCameraInfo(const bag::BagMessage& message, TopicPlan& plan) {
    const auto msg = decode(plan, [&] { return message.cameraInfo(); });
    const std::optional<Camera> camera = convertInfo(plan, msg);
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
             ") differs from the " + state.calibration_source + " (" + state.camera->description() +
             "); using the file");
      } else {
        warn("topic " + plan.mapping.topic + ": CameraInfo changes during the recording (message " +
             std::to_string(plan.messages) + ": " + camera->description() +
             "); keeping the first one (" + state.camera->description() + ")");
      }
      plan.info_changed_warned = true;
    }
  }

  /// The transforms of a TFMessage to the mapping's child frame (from its
  /// parent frame, when the mapping names one), each as a pose.
  void handleTransforms(const bag::BagMessage& message, TopicPlan& plan, DatasetWriter& writer) {
    const auto transforms = decode(plan, [&] { return message.transforms(); });
    for (const geometry_msgs::TransformStamped& transform : transforms) {
      if (transform.child_frame_id != plan.mapping.child_frame) continue;
      if (!plan.mapping.parent_frame.empty() &&
          transform.header.frame_id != plan.mapping.parent_frame) {
        if (!plan.parent_mismatch_warned) {
          warn("topic " + plan.mapping.topic + ": the transform to '" + transform.child_frame_id +
               "' is from '" + transform.header.frame_id + "', not '" + plan.mapping.parent_frame +
               "'; skipped");
        }
        plan.parent_mismatch_warned = true;
        continue;
      }
      writePose(message, plan, writer, transform.header.stamp, poseOfTransform(transform),
                transform.child_frame_id);
    }
  }

  /// `child_frame`: the frame the pose is of, when the message names it.
  void writePose(const bag::BagMessage& message, TopicPlan& plan, DatasetWriter& writer,
                 const ros::Time& stamp, const geometry_msgs::Pose& pose,
                 const std::string& child_frame = "") {
    const TimeNs t = messageTime(message, plan, stamp);
    PoseSample sample;
    sample.t = t;
    sample.label = plan.label;
    try {
      sample.world_from_body = poseFromRos(pose);
    } catch (const Problem& problem) {
      fail(plan, problem.why);
    }
    if (!plan.mapping.body_frame.empty())
      sample.world_from_body = sample.world_from_body * childFromBody(plan, child_frame);
    if (!acceptTime("poses", plan.label, t)) return;
    write(writer, std::move(sample));
  }

  /// The mount from the messages' frame to the mapping's body frame, through /tf_static.
  const Rigid3d& childFromBody(TopicPlan& plan, const std::string& child_frame) {
    if (const auto it = plan.child_from_body.find(child_frame); it != plan.child_from_body.end())
      return it->second;
    if (child_frame.empty()) fail(plan, "the message names no child frame for body_frame");
    const std::optional<Rigid3d> mount =
        static_frames_.between(child_frame, plan.mapping.body_frame);
    if (!mount) {
      fail(plan, "no static transforms connect '" + child_frame + "' (the poses' frame) to '" +
                     plan.mapping.body_frame +
                     "' (body_frame) in /tf_static; its transforms: " + static_frames_.describe());
    }
    return plan.child_from_body.emplace(child_frame, *mount).first->second;
  }

  void write(DatasetWriter& writer, Record record) {
    writer.write(record);
    ++stats_->records;
  }

  fs::path bag_path_;
  const RosbagImportOptions& options_;
  RosbagImportStats* stats_;
  std::unique_ptr<bag::BagSource> source_;
  std::map<std::string, TopicPlan> plans_;
  std::map<std::string, CameraState> cameras_;
  std::vector<std::string> camera_order_;
  std::map<std::string, StreamState> streams_;
  StaticFrames static_frames_;
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
  importer.readStaticTransforms();
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

namespace lookboth::bag {

std::optional<MessageKind> kindOfType(const std::string& type) {
  // ROS 2 names carry "/msg/" between package and message.
  std::string ros1 = type;
  if (const size_t at = ros1.find("/msg/"); at != std::string::npos) ros1.erase(at, 4);
  static const std::map<std::string, MessageKind> kinds = {
      {"sensor_msgs/Image", MessageKind::kImage},
      {"sensor_msgs/CompressedImage", MessageKind::kCompressedImage},
      {"sensor_msgs/CameraInfo", MessageKind::kCameraInfo},
      {"nav_msgs/Odometry", MessageKind::kOdometry},
      {"geometry_msgs/PoseStamped", MessageKind::kPoseStamped},
      {"geometry_msgs/PoseWithCovarianceStamped", MessageKind::kPoseWithCovarianceStamped},
      {"tf2_msgs/TFMessage", MessageKind::kTransforms},
  };
  const auto it = kinds.find(ros1);
  if (it == kinds.end()) return std::nullopt;
  return it->second;
}

std::vector<std::string> supportedTypeNames(bool ros2) {
  std::vector<std::string> names;
  for (const char* type :
       {"sensor_msgs/Image", "sensor_msgs/CompressedImage", "sensor_msgs/CameraInfo",
        "nav_msgs/Odometry", "geometry_msgs/PoseStamped", "geometry_msgs/PoseWithCovarianceStamped",
        "tf2_msgs/TFMessage"}) {
    std::string name = type;
    if (ros2) name.insert(name.find('/'), "/msg");
    names.push_back(name);
  }
  return names;
}

}  // namespace lookboth::bag
