#include "lookboth/dataset/manifest.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <set>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/core/yaml_reader.h"

namespace lookboth {

const std::map<std::string, int>& knownMarkerDictionaries() {
  static const std::map<std::string, int> kDictionaries = {
      {"DICT_4X4_50", 50},        {"DICT_4X4_100", 100},         {"DICT_4X4_250", 250},
      {"DICT_4X4_1000", 1000},    {"DICT_5X5_50", 50},           {"DICT_5X5_100", 100},
      {"DICT_5X5_250", 250},      {"DICT_5X5_1000", 1000},       {"DICT_6X6_50", 50},
      {"DICT_6X6_100", 100},      {"DICT_6X6_250", 250},         {"DICT_6X6_1000", 1000},
      {"DICT_7X7_50", 50},        {"DICT_7X7_100", 100},         {"DICT_7X7_250", 250},
      {"DICT_7X7_1000", 1000},    {"DICT_ARUCO_ORIGINAL", 1024}, {"DICT_APRILTAG_16h5", 30},
      {"DICT_APRILTAG_25h9", 35}, {"DICT_APRILTAG_36h10", 2320}, {"DICT_APRILTAG_36h11", 587}};
  return kDictionaries;
}

std::string MarkerSpec::check() const {
  const auto& dictionaries = knownMarkerDictionaries();
  const auto it = dictionaries.find(dictionary);
  if (it == dictionaries.end()) {
    std::string names;
    for (const auto& [name, size] : dictionaries) names += (names.empty() ? "" : ", ") + name;
    return "'dictionary': unknown '" + dictionary + "' (known: " + names + ")";
  }
  if (id < 0 || id >= it->second) {
    return "'id': " + std::to_string(id) + " is not in " + dictionary + " (ids 0.." +
           std::to_string(it->second - 1) + ")";
  }
  if (!(size_m > 0.0) || !std::isfinite(size_m)) {
    return "'size_m': must be a positive length in metres, got " + formatDouble(size_m);
  }
  return "";
}

const char* sensorRoleName(SensorRole role) {
  return role == SensorRole::kFisheye ? "fisheye" : "env_camera";
}

const CameraSensor* Manifest::findCamera(const std::string& label) const {
  for (const CameraSensor& c : cameras) {
    if (c.label == label) return &c;
  }
  return nullptr;
}

const CameraSensor* Manifest::fisheye() const {
  for (const CameraSensor& c : cameras) {
    if (c.role == SensorRole::kFisheye) return &c;
  }
  return nullptr;
}

const TrajectoryInfo* Manifest::findTrajectory(const std::string& label) const {
  for (const TrajectoryInfo& t : trajectories) {
    if (t.label == label) return &t;
  }
  return nullptr;
}

std::string Manifest::check() const {
  if (const std::string why = marker.check(); !why.empty()) return "marker: " + why;
  std::set<std::string> labels;
  for (size_t i = 0; i < cameras.size(); ++i) {
    const std::string& label = cameras[i].label;
    if (label.empty()) return "'cameras[" + std::to_string(i) + "].label': empty";
    if (label.find_first_of(",/\\ \t\n") != std::string::npos) {
      return "'cameras[" + std::to_string(i) + "].label': '" + label +
             "' must not contain commas, slashes or spaces";
    }
    if (!labels.insert(label).second) return "'cameras': label '" + label + "' appears twice";
  }
  std::set<std::string> trajectory_labels;
  for (const TrajectoryInfo& t : trajectories) {
    if (t.label.empty()) return "'trajectories': empty label";
    if (labels.count(t.label))
      return "'trajectories': label '" + t.label + "' is also a camera label";
    if (!trajectory_labels.insert(t.label).second) {
      return "'trajectories': label '" + t.label + "' appears twice";
    }
  }
  for (const auto& [label, pose] : ground_truth.world_from_camera) {
    const CameraSensor* camera = findCamera(label);
    if (!camera || camera->role != SensorRole::kEnvCamera) {
      return "'ground_truth.world_from_camera." + label + "': no environment camera has that label";
    }
  }
  for (const auto& [label, offset] : ground_truth.clock_offset) {
    if (!labels.count(label))
      return "'ground_truth.clock_offsets_ns." + label + "': unknown sensor";
  }
  for (const auto& [label, spans] : ground_truth.hidden_from_fisheye) {
    const std::string field = "'ground_truth.hidden_from_fisheye." + label + "'";
    const CameraSensor* camera = findCamera(label);
    if (!camera || camera->role != SensorRole::kEnvCamera)
      return field + ": no environment camera has that label";
    for (size_t i = 0; i < spans.size(); ++i) {
      if (spans[i].end < spans[i].begin) return field + ": a span ends before it begins";
      if (i > 0 && spans[i].begin <= spans[i - 1].end)
        return field + ": spans overlap or are not in time order";
    }
  }
  return "";
}

bool GroundTruth::hiddenFromFisheye(const std::string& camera, TimeNs t) const {
  const auto found = hidden_from_fisheye.find(camera);
  if (found == hidden_from_fisheye.end()) return false;
  const std::vector<TimeSpan>& spans = found->second;
  const auto after = std::upper_bound(spans.begin(), spans.end(), t,
                                      [](TimeNs x, const TimeSpan& s) { return x < s.begin; });
  return after != spans.begin() && std::prev(after)->contains(t);
}

namespace {

// ---- writing ----

void emitPose(YAML::Emitter& out, const Rigid3d& pose) {
  const Eigen::Quaterniond q = pose.rotation.normalized();
  out << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "tx" << YAML::Value << formatDouble(pose.translation.x());
  out << YAML::Key << "ty" << YAML::Value << formatDouble(pose.translation.y());
  out << YAML::Key << "tz" << YAML::Value << formatDouble(pose.translation.z());
  out << YAML::Key << "qx" << YAML::Value << formatDouble(q.x());
  out << YAML::Key << "qy" << YAML::Value << formatDouble(q.y());
  out << YAML::Key << "qz" << YAML::Value << formatDouble(q.z());
  out << YAML::Key << "qw" << YAML::Value << formatDouble(q.w());
  out << YAML::EndMap;
}

// ---- reading ----

// The shared strict reader plus the pose mapping used in manifests.
struct Reader : YamlReader {
  using YamlReader::YamlReader;

  Rigid3d pose(const YAML::Node& node, const std::string& field) const {
    if (!node.IsMap())
      throw Error(at(node, field), "expected a mapping {tx, ty, tz, qx, qy, qz, qw}");
    const char* keys[7] = {"tx", "ty", "tz", "qx", "qy", "qz", "qw"};
    double v[7];
    for (int i = 0; i < 7; ++i) {
      v[i] = number(require(node, keys[i], field + "." + keys[i]), field + "." + keys[i]);
    }
    Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > 1e-3) {
      throw Error(at(node, field), "quaternion norm is " + formatFixed(norm, 6) + ", expected 1");
    }
    q.normalize();
    return Rigid3d(q, Eigen::Vector3d(v[0], v[1], v[2]));
  }
};

// ground_truth.hidden_from_fisheye: {label: [[begin_ns, end_ns], ...]}; the
// spans' order is checked with the rest by Manifest::check.
void readHiddenFromFisheye(const Reader& r, const YAML::Node& hidden, GroundTruth& truth) {
  const std::string field = "ground_truth.hidden_from_fisheye";
  if (!hidden.IsMap()) throw Error(r.at(hidden, field), "expected a mapping label: spans");
  for (const auto& entry : hidden) {
    const std::string label = r.key(entry.first, field);
    const std::string at = field + "." + label;
    if (!entry.second.IsSequence())
      throw Error(r.at(entry.second, at), "expected a list of [begin_ns, end_ns]");
    std::vector<TimeSpan>& spans = truth.hidden_from_fisheye[label];
    for (const YAML::Node& span : entry.second) {
      if (!span.IsSequence() || span.size() != 2)
        throw Error(r.at(span, at), "expected [begin_ns, end_ns]");
      spans.push_back({r.integer(span[0], at), r.integer(span[1], at)});
    }
  }
}

}  // namespace

std::string manifestToYaml(const Manifest& manifest) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "lookboth_dataset" << YAML::Value << 1;
  out << YAML::Key << "name" << YAML::Value << manifest.name;
  out << YAML::Key << "marker" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "dictionary" << YAML::Value << manifest.marker.dictionary;
  out << YAML::Key << "id" << YAML::Value << manifest.marker.id;
  out << YAML::Key << "size_m" << YAML::Value << formatDouble(manifest.marker.size_m);
  out << YAML::EndMap;
  out << YAML::Key << "cameras" << YAML::Value << YAML::BeginSeq;
  for (const CameraSensor& camera : manifest.cameras) {
    out << YAML::BeginMap;
    out << YAML::Key << "label" << YAML::Value << camera.label;
    out << YAML::Key << "role" << YAML::Value << sensorRoleName(camera.role);
    if (camera.camera) {
      out << YAML::Key << "calibration" << YAML::Value << YAML::Load(cameraToYaml(*camera.camera));
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "trajectories" << YAML::Value << YAML::BeginSeq;
  for (const TrajectoryInfo& t : manifest.trajectories) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "label" << YAML::Value << t.label;
    out << YAML::Key << "metric" << YAML::Value << t.metric;
    if (!t.description.empty()) out << YAML::Key << "description" << YAML::Value << t.description;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (!manifest.ground_truth.empty()) {
    const GroundTruth& gt = manifest.ground_truth;
    out << YAML::Key << "ground_truth" << YAML::Value << YAML::BeginMap;
    if (gt.fisheye_from_marker) {
      out << YAML::Key << "fisheye_from_marker" << YAML::Value;
      emitPose(out, *gt.fisheye_from_marker);
    }
    if (!gt.world_from_camera.empty()) {
      out << YAML::Key << "world_from_camera" << YAML::Value << YAML::BeginMap;
      for (const auto& [label, pose] : gt.world_from_camera) {
        out << YAML::Key << label << YAML::Value;
        emitPose(out, pose);
      }
      out << YAML::EndMap;
    }
    if (!gt.clock_offset.empty()) {
      out << YAML::Key << "clock_offsets_ns" << YAML::Value << YAML::BeginMap;
      for (const auto& [label, offset] : gt.clock_offset) {
        out << YAML::Key << label << YAML::Value << static_cast<long long>(offset);
      }
      out << YAML::EndMap;
    }
    if (!gt.hidden_from_fisheye.empty()) {
      out << YAML::Key << "hidden_from_fisheye" << YAML::Value << YAML::BeginMap;
      for (const auto& [label, spans] : gt.hidden_from_fisheye) {
        out << YAML::Key << label << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (const TimeSpan& span : spans) {
          out << YAML::BeginSeq << static_cast<long long>(span.begin)
              << static_cast<long long>(span.end) << YAML::EndSeq;
        }
        out << YAML::EndSeq;
      }
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  if (manifest.rawlog_entries >= 0) {
    out << YAML::Key << "rawlog_entries" << YAML::Value
        << static_cast<long long>(manifest.rawlog_entries);
  }
  out << YAML::EndMap;
  return std::string("# lookboth dataset manifest (doc/formats.md)\n") + out.c_str() + "\n";
}

Manifest manifestFromYaml(const std::string& yaml, const std::string& source) {
  const Reader r(source);
  const YAML::Node root = r.parse(yaml);
  if (!root.IsMap()) throw Error({source, 0, "", ""}, "expected a YAML mapping");
  r.rejectUnknownKeys(root,
                      {"lookboth_dataset", "name", "marker", "cameras", "trajectories",
                       "ground_truth", "rawlog_entries"},
                      "");
  const long long version =
      r.integer(r.require(root, "lookboth_dataset", "lookboth_dataset"), "lookboth_dataset");
  if (version != 1) {
    throw Error(
        r.at(root["lookboth_dataset"], "lookboth_dataset"),
        "version " + std::to_string(version) + " is not supported (this lookboth reads version 1)");
  }
  Manifest manifest;
  if (root["name"]) manifest.name = r.text(root["name"], "name");

  const YAML::Node marker = r.require(root, "marker", "marker");
  r.rejectUnknownKeys(marker, {"dictionary", "id", "size_m"}, "marker");
  manifest.marker.dictionary =
      r.text(r.require(marker, "dictionary", "marker.dictionary"), "marker.dictionary");
  manifest.marker.id = r.int32(r.require(marker, "id", "marker.id"), "marker.id");
  manifest.marker.size_m = r.number(r.require(marker, "size_m", "marker.size_m"), "marker.size_m");
  if (const std::string why = manifest.marker.check(); !why.empty()) {
    throw Error(r.at(marker, "marker"), why);
  }

  if (const YAML::Node cameras = root["cameras"]; cameras && !cameras.IsNull()) {
    if (!cameras.IsSequence()) throw Error(r.at(cameras, "cameras"), "expected a list");
    for (size_t i = 0; i < cameras.size(); ++i) {
      const YAML::Node node = cameras[i];
      const std::string field = "cameras[" + std::to_string(i) + "]";
      r.rejectUnknownKeys(node, {"label", "role", "calibration"}, field);
      CameraSensor sensor;
      sensor.label = r.text(r.require(node, "label", field + ".label"), field + ".label");
      const std::string role = r.text(r.require(node, "role", field + ".role"), field + ".role");
      if (role == "fisheye") {
        sensor.role = SensorRole::kFisheye;
      } else if (role == "env_camera") {
        sensor.role = SensorRole::kEnvCamera;
      } else {
        throw Error(r.at(node["role"], field + ".role"),
                    "unknown role '" + role + "' (fisheye, env_camera)");
      }
      if (const YAML::Node calibration = node["calibration"];
          calibration && !calibration.IsNull()) {
        YAML::Emitter text;
        text << calibration;
        try {
          sensor.camera =
              cameraFromYaml(text.c_str(), source + " (" + field + ".calibration, line " +
                                               std::to_string(calibration.Mark().line + 1) + ")");
        } catch (const Error& e) {
          throw Error(ErrorContext{"", 0, "", sensor.label}, e.what());
        }
      }
      manifest.cameras.push_back(std::move(sensor));
    }
  }

  if (const YAML::Node trajectories = root["trajectories"];
      trajectories && !trajectories.IsNull()) {
    if (!trajectories.IsSequence())
      throw Error(r.at(trajectories, "trajectories"), "expected a list");
    for (size_t i = 0; i < trajectories.size(); ++i) {
      const YAML::Node node = trajectories[i];
      const std::string field = "trajectories[" + std::to_string(i) + "]";
      r.rejectUnknownKeys(node, {"label", "metric", "description"}, field);
      TrajectoryInfo info;
      info.label = r.text(r.require(node, "label", field + ".label"), field + ".label");
      info.metric = r.boolean(r.require(node, "metric", field + ".metric"), field + ".metric");
      if (node["description"])
        info.description = r.text(node["description"], field + ".description");
      manifest.trajectories.push_back(std::move(info));
    }
  }

  if (const YAML::Node gt = root["ground_truth"]; gt && !gt.IsNull()) {
    r.rejectUnknownKeys(
        gt, {"fisheye_from_marker", "world_from_camera", "clock_offsets_ns", "hidden_from_fisheye"},
        "ground_truth");
    if (gt["fisheye_from_marker"]) {
      manifest.ground_truth.fisheye_from_marker =
          r.pose(gt["fisheye_from_marker"], "ground_truth.fisheye_from_marker");
    }
    if (const YAML::Node cams = gt["world_from_camera"]; cams) {
      if (!cams.IsMap()) {
        throw Error(r.at(cams, "ground_truth.world_from_camera"), "expected a mapping label: pose");
      }
      for (const auto& entry : cams) {
        const std::string label = r.key(entry.first, "ground_truth.world_from_camera");
        manifest.ground_truth.world_from_camera[label] =
            r.pose(entry.second, "ground_truth.world_from_camera." + label);
      }
    }
    if (const YAML::Node offsets = gt["clock_offsets_ns"]; offsets) {
      if (!offsets.IsMap()) {
        throw Error(r.at(offsets, "ground_truth.clock_offsets_ns"), "expected a mapping label: ns");
      }
      for (const auto& entry : offsets) {
        const std::string label = r.key(entry.first, "ground_truth.clock_offsets_ns");
        manifest.ground_truth.clock_offset[label] =
            r.integer(entry.second, "ground_truth.clock_offsets_ns." + label);
      }
    }
    if (const YAML::Node hidden = gt["hidden_from_fisheye"]; hidden)
      readHiddenFromFisheye(r, hidden, manifest.ground_truth);
  }
  if (root["rawlog_entries"])
    manifest.rawlog_entries = r.integer(root["rawlog_entries"], "rawlog_entries");

  if (const std::string why = manifest.check(); !why.empty()) throw Error({source, 0, "", ""}, why);
  return manifest;
}

Manifest loadManifest(const std::filesystem::path& path) {
  return manifestFromYaml(readFile(path), path.string());
}

void saveManifest(const Manifest& manifest, const std::filesystem::path& path) {
  writeFileAtomically(path, manifestToYaml(manifest));
}

}  // namespace lookboth
