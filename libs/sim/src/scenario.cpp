#include "lookboth/sim/scenario.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>

#include "lookboth/core/error.h"
#include "lookboth/core/paths.h"
#include "lookboth/core/text.h"
#include "lookboth/core/yaml_reader.h"

namespace lookboth::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

std::uint64_t fnv1a(std::string_view text, std::uint64_t hash = 14695981039346656037ULL) {
  for (const char c : text) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ULL;
  }
  return hash;
}

/// "'field': message" -> (field, message); the whole text as the message otherwise.
std::pair<std::string, std::string> splitFieldMessage(const std::string& text) {
  if (text.size() > 2 && text.front() == '\'') {
    const size_t end = text.find("': ");
    if (end != std::string::npos) return {text.substr(1, end - 1), text.substr(end + 3)};
  }
  return {"", text};
}

// ---------------------------------------------------------------------------
// YAML reading

// The shared strict reader (lookboth/core/yaml_reader.h) plus what scenarios
// need on top: line bookkeeping, number lists, calibration file lookup.
class Parser : public YamlReader {
 public:
  Parser(std::string source, fs::path base_dir, Scenario& scenario)
      : YamlReader(std::move(source)), base_dir_(std::move(base_dir)), scenario_(scenario) {}

  void note(const std::string& field, const YAML::Node& node) {
    if (node.IsDefined() && node.Mark().line >= 0)
      scenario_.lines[field] = static_cast<int>(node.Mark().line) + 1;
  }

  std::vector<double> numbers(const YAML::Node& node, const std::string& field,
                              size_t count) const {
    if (!node.IsSequence()) throw Error(at(node, field), "expected a list of numbers");
    if (count != 0 && node.size() != count) {
      throw Error(at(node, field), "expected " + std::to_string(count) + " numbers, got " +
                                       std::to_string(node.size()));
    }
    std::vector<double> out;
    for (size_t i = 0; i < node.size(); ++i)
      out.push_back(number(node[i], field + "[" + std::to_string(i) + "]"));
    return out;
  }

  /// A data file (a replay's TUM files): a relative path is beside the scenario.
  fs::path dataFile(const YAML::Node& node, const std::string& field) const {
    const fs::path given = text(node, field);
    if (given.empty()) throw Error(at(node, field), "empty path");
    const fs::path path = given.is_absolute() || base_dir_.empty() ? given : base_dir_ / given;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) throw Error(at(node, field), "no file " + path.string());
    return fs::absolute(path).lexically_normal();
  }

  /// A calibration file: relative paths are looked up beside the scenario,
  /// then in share/lookboth/cameras.
  fs::path calibration(const YAML::Node& node, const std::string& field) const {
    const fs::path given = text(node, field);
    if (given.empty()) throw Error(at(node, field), "empty path");
    std::vector<fs::path> candidates;
    if (given.is_absolute()) {
      candidates.push_back(given);
    } else {
      if (!base_dir_.empty()) candidates.push_back(base_dir_ / given);
      candidates.push_back(shareDirectory() / "cameras" / given);
    }
    std::error_code ec;
    for (const fs::path& candidate : candidates) {
      if (fs::is_regular_file(candidate, ec)) return fs::absolute(candidate).lexically_normal();
    }
    std::string tried;
    for (const fs::path& candidate : candidates) tried += " " + candidate.string();
    throw Error(at(node, field), "calibration file not found (tried:" + tried + ")");
  }

 private:
  fs::path base_dir_;
  Scenario& scenario_;
};

/// One YAML mapping: keys are read by name, unknown keys are errors.
class Section {
 public:
  Section(Parser& parser, YAML::Node node, std::string path)
      : parser_(parser), node_(std::move(node)), path_(std::move(path)) {
    if (node_.IsDefined() && !node_.IsNull() && !node_.IsMap())
      throw Error(parser_.at(node_, path_.empty() ? "(top level)" : path_), "expected a mapping");
  }

  std::string field(const std::string& key) const {
    return path_.empty() ? key : path_ + "." + key;
  }

  /// The value of `key`, or an undefined node.
  YAML::Node get(const std::string& key) {
    known_.insert(key);
    if (!node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    YAML::Node value = node_[key];
    if (value.IsDefined() && !value.IsNull()) {
      parser_.note(field(key), value);
      return value;
    }
    return YAML::Node(YAML::NodeType::Undefined);
  }
  YAML::Node require(const std::string& key) {
    YAML::Node value = get(key);
    if (!value.IsDefined()) throw Error(parser_.at(node_, field(key)), "missing (required)");
    return value;
  }
  void number(const std::string& key, double& out) {
    if (const YAML::Node v = get(key); v.IsDefined()) out = parser_.number(v, field(key));
  }
  void integer(const std::string& key, int& out) {
    if (const YAML::Node v = get(key); v.IsDefined()) {
      const long long value = parser_.integer(v, field(key));
      if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max())
        throw Error(parser_.at(v, field(key)), "out of range");
      out = static_cast<int>(value);
    }
  }
  void text(const std::string& key, std::string& out) {
    if (const YAML::Node v = get(key); v.IsDefined()) out = parser_.text(v, field(key));
  }
  void boolean(const std::string& key, bool& out) {
    if (const YAML::Node v = get(key); v.IsDefined()) out = parser_.boolean(v, field(key));
  }
  void vector3(const std::string& key, Eigen::Vector3d& out) {
    if (const YAML::Node v = get(key); v.IsDefined()) {
      const std::vector<double> values = parser_.numbers(v, field(key), 3);
      out = Eigen::Vector3d(values[0], values[1], values[2]);
    }
  }
  Section sub(const std::string& key) { return Section(parser_, get(key), field(key)); }
  bool has(const std::string& key) {
    known_.insert(key);
    return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
  }

  /// Rejects the keys nobody asked for.
  void finish() const {
    if (!node_.IsMap()) return;
    for (const auto& entry : node_) {
      const std::string key = entry.first.Scalar();
      if (!known_.count(key)) {
        std::string list;
        for (const std::string& k : known_) list += (list.empty() ? "" : ", ") + k;
        throw Error(parser_.at(entry.first, field(key)), "unknown key (known: " + list + ")");
      }
    }
  }

 private:
  Parser& parser_;
  YAML::Node node_;
  std::string path_;
  std::set<std::string> known_;
};

void readWorld(Section s, WorldSpec& w) {
  s.number("length_m", w.length_m);
  s.number("width_m", w.width_m);
  s.number("ceiling_min_m", w.ceiling_min_m);
  s.number("ceiling_max_m", w.ceiling_max_m);
  s.number("slab_size_m", w.slab_size_m);
  s.integer("beams", w.beams);
  s.integer("ducts", w.ducts);
  s.integer("light_panels", w.light_panels);
  s.integer("cable_trays", w.cable_trays);
  s.integer("vents", w.vents);
  s.finish();
}

void readRobot(Parser& p, Section s, Scenario& scenario) {
  RobotSpec& r = scenario.robot;
  MotionSpec& m = r.motion;
  const bool has_loop = s.has("loop");
  const bool has_generated = s.has("generate_loop");
  const bool has_replay = s.has("replay");
  const int drives = int(has_loop) + int(has_generated) + int(has_replay);
  if (drives != 1) {
    throw Error(
        ErrorContext{p.source(), scenario.lines.count("robot") ? scenario.lines["robot"] : 0,
                     "robot.loop", ""},
        drives > 1 ? "give one of 'loop', 'generate_loop' and 'replay', not several"
                   : "missing: give 'loop' (waypoints), 'generate_loop' or 'replay' (a recorded "
                     "path)");
  }
  // Motion limits first: the generated loop uses the corner radius.
  s.number("corner_radius_m", m.corner_radius_m);
  s.number("max_speed_mps", m.max_speed_mps);
  s.number("max_acceleration_mps2", m.max_acceleration_mps2);
  s.number("max_lateral_acceleration_mps2", m.max_lateral_acceleration_mps2);
  s.number("speed_smoothing_m", m.speed_smoothing_m);
  s.integer("laps", m.laps);
  s.number("wait_s", m.wait_s);
  if (has_replay) {
    Section replay = s.sub("replay");
    replay.require("path");
    r.replay.path = p.dataFile(replay.get("path"), "robot.replay.path");
    if (const YAML::Node odometry = replay.get("odometry"); odometry.IsDefined())
      r.replay.odometry = p.dataFile(odometry, "robot.replay.odometry");
    replay.boolean("metric", r.replay.metric);
    replay.number("scale", r.replay.scale);
    replay.number("rotate_deg", r.replay.rotate_deg);
    replay.finish();
  } else if (has_loop) {
    const YAML::Node loop = s.get("loop");
    if (!loop.IsSequence())
      throw Error(p.at(loop, "robot.loop"), "expected a list of [x, y] points");
    for (size_t i = 0; i < loop.size(); ++i) {
      const std::vector<double> xy = p.numbers(loop[i], "robot.loop[" + std::to_string(i) + "]", 2);
      m.loop.emplace_back(xy[0], xy[1]);
    }
  } else {
    const YAML::Node node = s.get("generate_loop");
    Section g(p, node, "robot.generate_loop");
    double length = 0, margin = 2.5;
    int notches = 2;
    g.number("length_m", length);
    g.number("margin_m", margin);
    g.integer("notches", notches);
    g.require("length_m");
    g.finish();
    try {
      // The rounded corners shorten the loop by (2 - pi/2) r each (90 deg).
      const int corners = 4 + 4 * notches;
      const double r = m.corner_radius_m;
      m.loop = generateCombLoop(scenario.world.length_m, scenario.world.width_m, margin, notches,
                                length + corners * (2.0 - kPi / 2) * r);
    } catch (const Error& e) {
      throw Error(p.at(node, "robot.generate_loop"), splitFieldMessage(e.message()).second);
    }
  }
  {
    Section floor = s.sub("floor");
    floor.number("amplitude_m", m.floor_amplitude_m);
    floor.number("wavelength_m", m.floor_wavelength_m);
    floor.finish();
  }
  {
    Section body = s.sub("body");
    body.number("length_m", r.body_length_m);
    body.number("width_m", r.body_width_m);
    body.number("height_m", r.body_height_m);
    body.finish();
  }
  {
    Section f = s.sub("fisheye");
    f.require("calibration");
    f.text("label", r.fisheye.label);
    r.fisheye.calibration = p.calibration(f.get("calibration"), "robot.fisheye.calibration");
    f.number("rate_hz", r.fisheye.rate_hz);
    f.vector3("position_m", r.fisheye.position_m);
    f.finish();
  }
  {
    Section mount = s.sub("marker_mount");
    mount.vector3("translation_m", r.marker_mount.translation_m);
    mount.number("roll_deg", r.marker_mount.roll_deg);
    mount.number("pitch_deg", r.marker_mount.pitch_deg);
    mount.number("yaw_deg", r.marker_mount.yaw_deg);
    mount.finish();
  }
  {
    Section o = s.sub("odometry");
    o.number("rate_hz", r.odometry.rate_hz);
    o.number("scale_error_sigma", r.odometry.scale_error_sigma);
    o.number("yaw_bias_sigma_deg_per_s", r.odometry.yaw_bias_sigma_deg_per_s);
    o.number("distance_noise_m_per_sqrt_m", r.odometry.distance_noise_m_per_sqrt_m);
    o.number("yaw_noise_deg_per_sqrt_m", r.odometry.yaw_noise_deg_per_sqrt_m);
    o.finish();
  }
  s.finish();
}

void readCameras(Parser& p, Section s, EnvCamerasSpec& c) {
  s.require("count");
  s.require("calibration");
  s.integer("count", c.count);
  s.text("label_prefix", c.label_prefix);
  c.calibration = p.calibration(s.get("calibration"), "cameras.calibration");
  s.number("rate_hz", c.rate_hz);
  if (const YAML::Node radius = s.get("store_radius_m"); radius.IsDefined()) {
    // "all": a full recording, every frame of the drive (a real camera's).
    c.store_radius_m = radius.IsScalar() && radius.Scalar() == "all"
                           ? std::numeric_limits<double>::infinity()
                           : p.number(radius, "cameras.store_radius_m");
  }
  s.number("mount_drop_m", c.mount_drop_m);
  s.number("tilt_max_deg", c.tilt_max_deg);
  s.number("lateral_offset_max_m", c.lateral_offset_max_m);
  s.number("min_spacing_m", c.min_spacing_m);
  s.number("housing_radius_m", c.housing_radius_m);
  s.number("housing_height_m", c.housing_height_m);
  if (s.has("video")) {
    Section v = s.sub("video");
    CameraVideoSpec video;
    v.text("codec", video.codec);
    v.integer("crf", video.crf);
    v.text("preset", video.preset);
    v.number("key_frame_interval_s", video.key_frame_interval_s);
    v.finish();
    c.video = video;
  }
  s.finish();
}

void readClocks(Parser& p, Section s, ClockSpec& c) {
  if (const YAML::Node node = s.get("start_time_s"); node.IsDefined()) {
    const auto t = parseSeconds(p.text(node, "clocks.start_time_s"));
    if (!t) throw Error(p.at(node, "clocks.start_time_s"), "expected a time in seconds");
    c.start_time = *t;
  }
  s.number("offset_min_ms", c.offset_min_ms);
  s.number("offset_max_ms", c.offset_max_ms);
  s.number("stamp_resolution_us", c.stamp_resolution_us);
  s.finish();
}

/// A list of mappings at `field` (absent: nothing), each read by
/// `item(section)` and then checked for unknown keys.
template <typename Item>
void readList(Parser& p, const YAML::Node& list, const std::string& field, const char* form,
              Item item) {
  if (!list.IsDefined()) return;
  if (!list.IsSequence()) throw Error(p.at(list, field), std::string("expected a list of ") + form);
  for (size_t i = 0; i < list.size(); ++i) {
    Section m(p, list[i], field + "[" + std::to_string(i) + "]");
    item(m);
    m.finish();
  }
}

void readFaults(Parser& p, Section s, FaultSpec& f) {
  s.number("drop_probability", f.drop_probability);
  {
    Section jump = s.sub("clock_jump");
    jump.text("node", f.clock_jump_node);
    jump.number("offset_ms", f.clock_jump_ms);
    jump.finish();
  }
  s.number("false_marker_rate", f.false_marker_rate);
  s.number("occlusion_probability", f.occlusion_probability);
  s.boolean("unvisited_camera", f.unvisited_camera);
  s.integer("duplicated_timestamps", f.duplicated_timestamps);
  readList(p, s.get("motion_blur"), "faults.motion_blur", "{start_s, end_s, blur_px}",
           [&](Section& b) {
             MotionBlurBurst burst;
             b.require("start_s");
             b.require("end_s");
             b.require("blur_px");
             b.number("start_s", burst.start_s);
             b.number("end_s", burst.end_s);
             b.number("blur_px", burst.blur_px);
             f.motion_blur.push_back(burst);
           });
  if (const YAML::Node region = s.get("low_texture_region"); region.IsDefined())
    f.low_texture_region = p.numbers(region, "faults.low_texture_region", 4);
  s.finish();
}

void readLaterDrive(Parser& p, Section s, LaterDriveSpec& later) {
  if (const YAML::Node seed = s.get("noise_seed"); seed.IsDefined()) {
    const long long value = p.integer(seed, "later_drive.noise_seed");
    if (value < 1 || value > std::numeric_limits<std::uint32_t>::max()) {
      throw Error(p.at(seed, "later_drive.noise_seed"), "must be in [1, 4294967295]");
    }
    later.noise_seed = static_cast<std::uint32_t>(value);
  }
  readList(p, s.get("moved"), "later_drive.moved", "{camera, translate_m, rotate_deg, replaced_by}",
           [&](Section& m) {
             CameraMove move;
             m.require("camera");
             m.text("camera", move.camera);
             m.vector3("translate_m", move.translate_m);
             m.vector3("rotate_deg", move.rotate_deg);
             m.text("replaced_by", move.replaced_by);
             later.moved.push_back(move);
           });
  s.finish();
}

void readFloorMarkers(Parser& p, const YAML::Node& list, std::vector<FloorMarkerSpec>& markers) {
  readList(p, list, "floor_markers", "{id, position_m, yaw_deg, size_m}", [&](Section& m) {
    FloorMarkerSpec marker;
    m.require("id");
    m.require("position_m");
    m.integer("id", marker.id);
    m.vector3("position_m", marker.position_m);
    m.number("yaw_deg", marker.yaw_deg);
    m.number("size_m", marker.size_m);
    markers.push_back(marker);
  });
}

std::optional<std::pair<std::string, std::string>> prefixed(const std::string& prefix,
                                                            const std::string& why) {
  if (why.empty()) return std::nullopt;
  auto [field, message] = splitFieldMessage(why);
  return std::make_pair(field.empty() ? prefix : prefix + "." + field, message);
}

std::optional<std::pair<std::string, std::string>> range(const std::string& field, double value,
                                                         double lo, double hi) {
  if (!(value >= lo && value <= hi)) {
    return std::make_pair(field, "must be in [" + formatDouble(lo) + ", " + formatDouble(hi) +
                                     "], got " + formatDouble(value));
  }
  return std::nullopt;
}

}  // namespace

// ---------------------------------------------------------------------------

Rigid3d MarkerMountSpec::fisheyeFromMarker() const {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw_deg * kDegree, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch_deg * kDegree, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll_deg * kDegree, Eigen::Vector3d::UnitX());
  return Rigid3d(q.normalized(), translation_m);
}

Rigid3d baseFromFisheye(const FisheyeSpec& fisheye) {
  Eigen::Matrix3d r;
  r.col(0) = Eigen::Vector3d(0, -1, 0);  // image right = the robot's right
  r.col(1) = Eigen::Vector3d(1, 0, 0);   // image down = the robot's front
  r.col(2) = Eigen::Vector3d(0, 0, 1);   // optical axis up
  return Rigid3d(Eigen::Quaterniond(r), fisheye.position_m);
}

bool FaultSpec::any() const {
  return drop_probability > 0 || (!clock_jump_node.empty() && clock_jump_ms != 0) ||
         false_marker_rate > 0 || occlusion_probability > 0 || unvisited_camera ||
         duplicated_timestamps > 0 || !motion_blur.empty() || !low_texture_region.empty();
}

namespace {

/// A label a camera can take: it names files and folders and starts CSV rows.
bool usableLabel(const std::string& label) {
  return !label.empty() && label.find_first_of(",/\\ ") == std::string::npos &&
         label.front() != '.' && label.front() != '#';
}

std::optional<std::pair<std::string, std::string>> laterDriveProblem(const LaterDriveSpec& later) {
  for (size_t i = 0; i < later.moved.size(); ++i) {
    const std::string& label = later.moved[i].replaced_by;
    if (!label.empty() && !usableLabel(label)) {
      return std::make_pair("later_drive.moved[" + std::to_string(i) + "].replaced_by",
                            "'" + label + "' is not a usable label");
    }
  }
  return std::nullopt;
}

std::optional<std::pair<std::string, std::string>> floorMarkersProblem(const Scenario& sc) {
  std::set<int> ids = {sc.marker.id};
  const int dictionary_size = knownMarkerDictionaries().at(sc.marker.dictionary);
  for (size_t i = 0; i < sc.floor_markers.size(); ++i) {
    const FloorMarkerSpec& m = sc.floor_markers[i];
    const std::string field = "floor_markers[" + std::to_string(i) + "]";
    if (m.id < 0 || m.id >= dictionary_size) {
      return std::make_pair(field + ".id", "must be in [0, " + std::to_string(dictionary_size - 1) +
                                               "] (" + sc.marker.dictionary + ")");
    }
    if (!ids.insert(m.id).second) {
      return std::make_pair(
          field + ".id", std::to_string(m.id) + " is the robot's marker or another floor marker");
    }
    if (auto p = range(field + ".size_m", m.size_m, 0.01, 5)) return p;
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::pair<std::string, std::string>> Scenario::problem() const {
  if (name.empty()) return std::make_pair(std::string("name"), std::string("empty"));
  if (auto p = prefixed("marker", marker.check())) return p;
  if (auto p = floorMarkersProblem(*this)) return p;
  if (auto p = laterDriveProblem(later_drive)) return p;
  {
    WorldSpec w = world;
    w.low_texture_region = faults.low_texture_region;
    const std::string why = w.check();
    if (!why.empty()) {
      auto [field, message] = splitFieldMessage(why);
      if (field == "low_texture_region") return std::make_pair("faults." + field, message);
      return std::make_pair(field.empty() ? std::string("world") : "world." + field, message);
    }
  }
  if (robot.replay.active()) {
    if (auto p = prefixed("robot.replay", robot.replay.check())) return p;
  } else if (auto p = prefixed("robot", robot.motion.check())) {
    // MotionSpec names its floor fields floor_*; the file nests them under robot.floor.
    if (p->first == "robot.floor_amplitude_m") p->first = "robot.floor.amplitude_m";
    if (p->first == "robot.floor_wavelength_m") p->first = "robot.floor.wavelength_m";
    return p;
  }
  for (size_t i = 0; i < robot.motion.loop.size(); ++i) {
    const Eigen::Vector2d& q = robot.motion.loop[i];
    if (q.x() < 0.3 || q.y() < 0.3 || q.x() > world.length_m - 0.3 || q.y() > world.width_m - 0.3) {
      return std::make_pair(std::string("robot.loop"),
                            "point " + std::to_string(i) + " (" + formatDouble(q.x()) + ", " +
                                formatDouble(q.y()) +
                                ") is not inside the facility (0.3 m from the walls)");
    }
  }
  if (auto p = range("robot.body.length_m", robot.body_length_m, 0.1, 3)) return p;
  if (auto p = range("robot.body.width_m", robot.body_width_m, 0.1, 3)) return p;
  if (auto p = range("robot.body.height_m", robot.body_height_m, 0.05, 2)) return p;
  if (robot.fisheye.label.empty() ||
      robot.fisheye.label.find_first_of(",/\\ ") != std::string::npos)
    return std::make_pair(std::string("robot.fisheye.label"),
                          "'" + robot.fisheye.label + "' is not a usable label");
  if (auto p = range("robot.fisheye.rate_hz", robot.fisheye.rate_hz, 0.1, 200)) return p;
  if (auto p = range("robot.fisheye.position_m[2]", robot.fisheye.position_m.z(),
                     robot.body_height_m, 2.0))
    return std::make_pair(p->first, "the fisheye's height above the floor " + p->second);
  {
    const Eigen::Vector3d marker_in_base =
        baseFromFisheye(robot.fisheye) * robot.marker_mount.translation_m;
    if (marker_in_base.z() < robot.body_height_m - 1e-9 || marker_in_base.z() > 2.0)
      return std::make_pair(std::string("robot.marker_mount.translation_m"),
                            "puts the marker " + formatFixed(marker_in_base.z(), 3) +
                                " m above the floor, below the body's top plate (" +
                                formatFixed(robot.body_height_m, 3) + " m)");
    if (robot.marker_mount.translation_m.norm() > 1.0)
      return std::make_pair(std::string("robot.marker_mount.translation_m"),
                            "more than 1 m from the fisheye");
    const Eigen::Vector3d normal =
        robot.marker_mount.fisheyeFromMarker().rotation * Eigen::Vector3d::UnitZ();
    if (normal.z() < std::cos(30 * kDegree))
      return std::make_pair(std::string("robot.marker_mount"),
                            "the marker must face up (within 30 deg)");
  }
  if (auto p = range("robot.odometry.rate_hz", robot.odometry.rate_hz, 0.1, 1000)) return p;
  if (auto p = range("robot.odometry.scale_error_sigma", robot.odometry.scale_error_sigma, 0, 0.2))
    return p;
  if (auto p = range("robot.odometry.yaw_bias_sigma_deg_per_s",
                     robot.odometry.yaw_bias_sigma_deg_per_s, 0, 10))
    return p;
  if (auto p = range("robot.odometry.distance_noise_m_per_sqrt_m",
                     robot.odometry.distance_noise_m_per_sqrt_m, 0, 1))
    return p;
  if (auto p = range("robot.odometry.yaw_noise_deg_per_sqrt_m",
                     robot.odometry.yaw_noise_deg_per_sqrt_m, 0, 30))
    return p;
  if (auto p = prefixed("marker", marker.check())) return p;
  if (auto p = range("cameras.count", cameras.count, 1, 1000)) return p;
  if (!usableLabel(cameras.label_prefix))
    return std::make_pair(std::string("cameras.label_prefix"),
                          "'" + cameras.label_prefix + "' cannot start a label");
  if (auto p = range("cameras.rate_hz", cameras.rate_hz, 0.1, 200)) return p;
  if (!std::isinf(cameras.store_radius_m)) {
    if (auto p = range("cameras.store_radius_m", cameras.store_radius_m, 0.1, 100)) return p;
  }
  if (auto p =
          range("cameras.mount_drop_m", cameras.mount_drop_m, cameras.housing_height_m + 0.01, 2.0))
    return std::make_pair(p->first, p->second + " (the housing hangs " +
                                        formatDouble(cameras.housing_height_m) +
                                        " m above the optical centre)");
  if (auto p = range("cameras.tilt_max_deg", cameras.tilt_max_deg, 0, 45)) return p;
  if (auto p = range("cameras.lateral_offset_max_m", cameras.lateral_offset_max_m, 0,
                     0.9 * cameras.store_radius_m))
    return std::make_pair(p->first, p->second + " (the robot must pass within store_radius_m)");
  if (auto p = range("cameras.min_spacing_m", cameras.min_spacing_m, 0, 1000)) return p;
  if (auto p = range("cameras.housing_radius_m", cameras.housing_radius_m, 0.01, 1)) return p;
  if (auto p = range("cameras.housing_height_m", cameras.housing_height_m, 0.01, 1)) return p;
  if (cameras.video) {
    if (auto p = prefixed("cameras.video", cameraVideoOptions(cameras).check())) return p;
    if (auto p = range("cameras.video.key_frame_interval_s", cameras.video->key_frame_interval_s,
                       1 / cameras.rate_hz, 3600))
      return p;
  }
  if (auto p = range("clocks.offset_min_ms", clocks.offset_min_ms, 0, 1e6)) return p;
  if (auto p = range("clocks.offset_max_ms", clocks.offset_max_ms, clocks.offset_min_ms, 1e6))
    return p;
  if (auto p = range("clocks.stamp_resolution_us", clocks.stamp_resolution_us, 0.1, 1e5)) return p;
  if (std::abs(std::round(clocks.stamp_resolution_us * 10) - clocks.stamp_resolution_us * 10) >
      1e-9)
    return std::make_pair(std::string("clocks.stamp_resolution_us"),
                          "must be a multiple of 0.1 us (MRPT's tick)");
  if (clocks.start_time < 0)
    return std::make_pair(std::string("clocks.start_time_s"), "must not be negative");
  if (auto p = range("render.fisheye_supersampling", render.fisheye_supersampling, 1, 8)) return p;
  if (auto p = range("render.env_supersampling", render.env_supersampling, 1, 8)) return p;
  if (auto p = range("render.noise_sigma", render.noise_sigma, 0, 50)) return p;
  if (auto p = range("render.exposure_jitter", render.exposure_jitter, 0, 0.9)) return p;
  if (auto p = range("render.png_compression", render.png_compression, 0, 9)) return p;
  if (auto p = range("noise.marker_corner_sigma_px", noise.marker_corner_sigma_px, 0, 20)) return p;
  if (auto p = range("noise.max_view_angle_deg", noise.max_view_angle_deg, 0, 89)) return p;
  if (auto p = range("noise.min_marker_px", noise.min_marker_px, 1, 1000)) return p;
  if (auto p = range("noise.image_margin_px", noise.image_margin_px, 0, 100)) return p;
  if (auto p = range("noise.blob_sigma_px", noise.blob_sigma_px, 0, 20)) return p;
  if (auto p = range("noise.marker_pass_share", noise.marker_pass_share, 0, 1)) return p;
  if (auto p = range("faults.drop_probability", faults.drop_probability, 0, 0.9)) return p;
  if (auto p = range("faults.false_marker_rate", faults.false_marker_rate, 0, 1)) return p;
  if (auto p = range("faults.occlusion_probability", faults.occlusion_probability, 0, 1)) return p;
  if (auto p = range("faults.duplicated_timestamps", faults.duplicated_timestamps, 0, 1e6))
    return p;
  if (!faults.clock_jump_node.empty() && faults.clock_jump_ms == 0)
    return std::make_pair(std::string("faults.clock_jump.offset_ms"),
                          "missing (a node is named, but no offset)");
  if (auto p = range("faults.clock_jump.offset_ms", faults.clock_jump_ms, -1e5, 1e5)) return p;
  for (size_t i = 0; i < faults.motion_blur.size(); ++i) {
    const MotionBlurBurst& b = faults.motion_blur[i];
    const std::string field = "faults.motion_blur[" + std::to_string(i) + "]";
    if (!(b.start_s >= 0) || !(b.end_s > b.start_s))
      return std::make_pair(field, "needs 0 <= start_s < end_s");
    if (auto p = range(field + ".blur_px", b.blur_px, 0, 200)) return p;
  }
  return std::nullopt;
}

std::string Scenario::check() const {
  const auto p = problem();
  return p ? "'" + p->first + "': " + p->second : std::string();
}

fs::path builtinScenarioDirectory() { return shareDirectory() / "scenarios"; }

std::vector<std::string> builtinScenarioNames() {
  std::vector<std::string> names;
  std::error_code ec;
  const fs::path dir = builtinScenarioDirectory();
  if (!fs::is_directory(dir, ec)) return names;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (entry.path().extension() == ".yaml") names.push_back(entry.path().stem().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

Scenario scenarioFromYaml(const std::string& yaml, const std::string& source,
                          const fs::path& base_dir) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    throw Error(ErrorContext{source, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", ""},
                "not valid YAML: " + e.msg);
  }
  Scenario scenario;
  Parser parser(source, base_dir, scenario);
  if (!root.IsMap()) throw Error(ErrorContext{source, 0, "", ""}, "expected a YAML mapping");
  Section top(parser, root, "");
  top.text("name", scenario.name);
  if (scenario.name.empty() && !source.empty()) scenario.name = fs::path(source).stem().string();
  top.text("description", scenario.description);
  if (const YAML::Node seed = top.get("seed"); seed.IsDefined()) {
    const long long value = parser.integer(seed, "seed");
    if (value < 0 || value > std::numeric_limits<std::uint32_t>::max())
      throw Error(parser.at(seed, "seed"), "must be in [0, 4294967295]");
    scenario.seed = static_cast<std::uint32_t>(value);
  }
  readWorld(top.sub("world"), scenario.world);
  {
    const YAML::Node robot = top.require("robot");
    readRobot(parser, Section(parser, robot, "robot"), scenario);
  }
  {
    Section marker = top.sub("marker");
    marker.text("dictionary", scenario.marker.dictionary);
    marker.integer("id", scenario.marker.id);
    marker.number("size_m", scenario.marker.size_m);
    marker.finish();
  }
  readCameras(parser, Section(parser, top.require("cameras"), "cameras"), scenario.cameras);
  readClocks(parser, top.sub("clocks"), scenario.clocks);
  {
    Section r = top.sub("render");
    r.integer("fisheye_supersampling", scenario.render.fisheye_supersampling);
    r.integer("env_supersampling", scenario.render.env_supersampling);
    r.number("noise_sigma", scenario.render.noise_sigma);
    r.number("exposure_jitter", scenario.render.exposure_jitter);
    r.integer("png_compression", scenario.render.png_compression);
    r.finish();
  }
  {
    Section n = top.sub("noise");
    n.number("marker_corner_sigma_px", scenario.noise.marker_corner_sigma_px);
    n.number("max_view_angle_deg", scenario.noise.max_view_angle_deg);
    n.number("min_marker_px", scenario.noise.min_marker_px);
    n.number("image_margin_px", scenario.noise.image_margin_px);
    n.number("blob_sigma_px", scenario.noise.blob_sigma_px);
    n.boolean("marker_corners", scenario.noise.marker_corners);
    n.number("marker_pass_share", scenario.noise.marker_pass_share);
    n.finish();
  }
  readFaults(parser, top.sub("faults"), scenario.faults);
  readLaterDrive(parser, top.sub("later_drive"), scenario.later_drive);
  readFloorMarkers(parser, top.get("floor_markers"), scenario.floor_markers);
  top.finish();
  scenario.source = source;
  if (const auto p = scenario.problem()) {
    // The line of the field, else of its closest parent that has one.
    int line = 0;
    for (std::string field = p->first; !field.empty();) {
      if (const auto it = scenario.lines.find(field); it != scenario.lines.end()) {
        line = it->second;
        break;
      }
      const size_t cut = field.find_last_of(".[");
      field = cut == std::string::npos ? "" : field.substr(0, cut);
    }
    throw Error(ErrorContext{source, line, p->first, ""}, p->second);
  }
  return scenario;
}

Scenario loadScenario(const std::string& name_or_file) {
  fs::path path;
  const bool looks_like_file = name_or_file.find('/') != std::string::npos ||
                               fs::path(name_or_file).extension() == ".yaml" ||
                               fs::path(name_or_file).extension() == ".yml";
  if (looks_like_file) {
    path = name_or_file;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec))
      throw Error(ErrorContext{name_or_file, 0, "", ""}, "no such scenario file");
  } else {
    const std::vector<std::string> names = builtinScenarioNames();
    if (std::find(names.begin(), names.end(), name_or_file) == names.end()) {
      std::string list;
      for (const std::string& n : names) list += (list.empty() ? "" : ", ") + n;
      throw Error("unknown scenario '" + name_or_file + "' (built-in scenarios: " +
                  (list.empty() ? "none found" : list) + "; or give a .yaml file)");
    }
    path = builtinScenarioDirectory() / (name_or_file + ".yaml");
  }
  std::ifstream in(path);
  if (!in) throw Error(ErrorContext{path.string(), 0, "", ""}, "cannot read");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return scenarioFromYaml(buffer.str(), looks_like_file ? name_or_file : path.string(),
                          fs::absolute(path).parent_path());
}

std::uint32_t streamSeed(std::uint32_t seed, std::string_view stream) {
  std::uint64_t h = fnv1a(stream);
  h ^= static_cast<std::uint64_t>(seed) * 0x9E3779B97F4A7C15ULL;
  h = (h ^ (h >> 31)) * 0xBF58476D1CE4E5B9ULL;
  h ^= h >> 29;
  return static_cast<std::uint32_t>(h ^ (h >> 32));
}

std::uint32_t itemSeed(std::uint32_t seed, std::string_view stream, std::int64_t index) {
  std::uint64_t h = static_cast<std::uint64_t>(streamSeed(seed, stream)) << 32 ^
                    static_cast<std::uint64_t>(index) * 0xD6E8FEB86659FD93ULL;
  h = (h ^ (h >> 32)) * 0xD6E8FEB86659FD93ULL;
  h ^= h >> 32;
  return static_cast<std::uint32_t>(h);
}

// ---------------------------------------------------------------------------
// Camera placement

std::vector<EnvCameraPlacement> placeEnvCameras(
    const Scenario& scenario, const RobotPath& motion,
    const std::function<double(double, double)>& ceiling_height_at, std::uint32_t seed) {
  const EnvCamerasSpec& spec = scenario.cameras;
  std::mt19937 rng(streamSeed(seed, "cameras"));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double loop_length = motion.loopLength();
  const double margin = 0.5;
  auto clampToWorld = [&](Eigen::Vector2d p) {
    p.x() = std::clamp(p.x(), margin, scenario.world.length_m - margin);
    p.y() = std::clamp(p.y(), margin, scenario.world.width_m - margin);
    return p;
  };

  // Points on the loop, greedily at least `spacing` apart (a path that
  // comes back along itself gets no second camera at the same place).
  const double start = unit(rng) * loop_length;
  double spacing =
      spec.min_spacing_m > 0 ? spec.min_spacing_m : loop_length / static_cast<double>(spec.count);
  std::vector<double> arcs;
  for (int attempt = 0; attempt < 60; ++attempt) {
    arcs.clear();
    std::vector<Eigen::Vector2d> points;
    for (double s = start;
         s < start + loop_length - 0.5 * spacing && static_cast<int>(arcs.size()) < spec.count;
         s += 0.05) {
      const Eigen::Vector2d p = motion.loopPoint(s);
      bool free = true;
      for (const Eigen::Vector2d& q : points) free = free && (p - q).norm() >= spacing;
      if (free) {
        arcs.push_back(s);
        points.push_back(p);
        s += 0.5 * spacing;
      }
    }
    if (static_cast<int>(arcs.size()) == spec.count) break;
    spacing *= 0.93;
  }
  if (static_cast<int>(arcs.size()) < spec.count)
    throw Error("'cameras.count': cannot place " + std::to_string(spec.count) +
                " cameras along a loop of " + formatFixed(loop_length, 1) + " m");

  const int total = spec.count + (scenario.faults.unvisited_camera ? 1 : 0);
  const int digits = total > 100 ? 3 : 2;
  auto label = [&](int i) {
    std::string number = std::to_string(i);
    while (static_cast<int>(number.size()) < digits) number.insert(0, "0");
    return spec.label_prefix + number;
  };
  auto orientation = [&]() {
    // Straight down, any yaw, then tilted by up to tilt_max in a random direction.
    const double yaw = unit(rng) * 2 * kPi;
    const double tilt = unit(rng) * spec.tilt_max_deg * kDegree;
    const double azimuth = unit(rng) * 2 * kPi;
    const Eigen::Quaterniond down = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX());
    const Eigen::Quaterniond tilt_q(
        Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), 0.0)));
    return Eigen::Quaterniond(tilt_q * down).normalized();
  };
  auto mount = [&](const Eigen::Vector2d& xy) {
    return Eigen::Vector3d(xy.x(), xy.y(), ceiling_height_at(xy.x(), xy.y()) - spec.mount_drop_m);
  };

  std::vector<EnvCameraPlacement> placements;
  const double jitter = 0.15 * spacing;
  for (int i = 0; i < spec.count; ++i) {
    const double s = arcs[static_cast<size_t>(i)] + (2 * unit(rng) - 1) * jitter;
    const double heading = motion.loopHeading(s);
    const Eigen::Vector2d normal(-std::sin(heading), std::cos(heading));
    const double offset = (2 * unit(rng) - 1) * spec.lateral_offset_max_m;
    const Eigen::Vector2d xy = clampToWorld(motion.loopPoint(s) + offset * normal);
    EnvCameraPlacement placement;
    placement.label = label(i);
    placement.world_from_camera = Rigid3d(orientation(), mount(xy));
    placements.push_back(placement);
  }
  std::sort(
      placements.begin(), placements.end(),
      [](const EnvCameraPlacement& a, const EnvCameraPlacement& b) { return a.label < b.label; });

  if (scenario.faults.unvisited_camera) {
    // The point of the facility farthest from the loop (ties broken at
    // random among the points within 10 % of the farthest).
    std::vector<std::pair<double, Eigen::Vector2d>> candidates;
    double best = 0;
    for (double x = 1.0; x <= scenario.world.length_m - 1.0; x += 0.5) {
      for (double y = 1.0; y <= scenario.world.width_m - 1.0; y += 0.5) {
        const Eigen::Vector2d p(x, y);
        const double d = motion.distanceToLoop(p);
        candidates.emplace_back(d, p);
        best = std::max(best, d);
      }
    }
    // With every frame stored, far enough that the marker is out of view.
    const double needed = (std::isinf(spec.store_radius_m) ? 2.5 : spec.store_radius_m) + 0.5;
    if (best < needed)
      throw Error("'faults.unvisited_camera': no place in the facility is " +
                  formatFixed(needed, 1) + " m from the loop (store_radius_m + 0.5 m); the " +
                  "farthest is " + formatFixed(best, 2) + " m: make the facility larger");
    std::vector<Eigen::Vector2d> good;
    for (const auto& [d, p] : candidates) {
      if (d >= std::max(needed, 0.9 * best)) good.push_back(p);
    }
    const size_t pick = std::min(good.size() - 1,
                                 static_cast<size_t>(unit(rng) * static_cast<double>(good.size())));
    EnvCameraPlacement placement;
    placement.label = label(spec.count);
    placement.world_from_camera = Rigid3d(orientation(), mount(good[pick]));
    placement.never_visited = true;
    placements.push_back(placement);
  }
  return placements;
}

VideoEncodeOptions cameraVideoOptions(const EnvCamerasSpec& cameras) {
  VideoEncodeOptions options;
  if (!cameras.video) return options;
  options.codec = cameras.video->codec;
  options.crf = cameras.video->crf;
  options.preset = cameras.video->preset;
  options.frame_rate_hz = cameras.rate_hz;
  options.key_frame_interval = std::max(
      1, static_cast<int>(std::lround(cameras.video->key_frame_interval_s * cameras.rate_hz)));
  return options;
}

}  // namespace lookboth::sim
