// Reading and writing the registration output directory (doc/formats.md,
// "Registration output"; the contract in lookboth/registration/registration.h).
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/core/yaml_reader.h"
#include "lookboth/geometry/tum.h"
#include "lookboth/registration/registration.h"

namespace lookboth {

const char* cameraStatusName(CameraStatus status) {
  switch (status) {
    case CameraStatus::kRegistered:
      return "registered";
    case CameraStatus::kSuspect:
      return "suspect";
    case CameraStatus::kUnregistered:
      return "unregistered";
  }
  return "?";
}

std::optional<CameraStatus> parseCameraStatus(const std::string& name) {
  if (name == "registered") return CameraStatus::kRegistered;
  if (name == "suspect") return CameraStatus::kSuspect;
  if (name == "unregistered") return CameraStatus::kUnregistered;
  return std::nullopt;
}

const char* trajectoryModeName(TrajectoryMode mode) {
  return mode == TrajectoryMode::kVisual ? "visual" : "metric";
}

std::optional<TrajectoryMode> parseTrajectoryMode(const std::string& name) {
  if (name == "visual") return TrajectoryMode::kVisual;
  if (name == "metric") return TrajectoryMode::kMetric;
  return std::nullopt;
}

const CameraRegistration* Registration::findCamera(const std::string& label) const {
  for (const CameraRegistration& camera : cameras) {
    if (camera.label == label) return &camera;
  }
  return nullptr;
}

namespace {

std::vector<std::string> labelled(const std::vector<std::string>& global,
                                  const std::vector<CameraRegistration>& cameras,
                                  std::vector<std::string> CameraRegistration::*messages) {
  std::vector<std::string> all = global;
  for (const CameraRegistration& c : cameras) {
    for (const std::string& m : c.*messages) all.push_back(c.label + ": " + m);
  }
  return all;
}

}  // namespace

std::vector<std::string> Registration::labelledWarnings() const {
  return labelled(warnings, cameras, &CameraRegistration::warnings);
}

std::vector<std::string> Registration::labelledNotes() const {
  return labelled(notes, cameras, &CameraRegistration::notes);
}

int Registration::registeredCount() const {
  int n = 0;
  for (const CameraRegistration& camera : cameras) {
    if (camera.status != CameraStatus::kUnregistered) ++n;
  }
  return n;
}

namespace {

constexpr const char* kFormat = "lookboth-registration 1";

// ---- writing ----

void emitNumbers(YAML::Emitter& out, const double* values, int n) {
  out << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < n; ++i) out << formatDouble(values[i]);
  out << YAML::EndSeq;
}

void emitPose(YAML::Emitter& out, const Rigid3d& pose) {
  const Eigen::Quaterniond q = pose.rotation.normalized();
  const double xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
  out << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "translation" << YAML::Value;
  emitNumbers(out, pose.translation.data(), 3);
  out << YAML::Key << "rotation_xyzw" << YAML::Value;
  emitNumbers(out, xyzw, 4);
  out << YAML::EndMap;
}

void emitCovariance(YAML::Emitter& out, const Matrix6d& covariance) {
  double values[36];
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) values[6 * r + c] = covariance(r, c);
  }
  emitNumbers(out, values, 36);
}

void emitStrings(YAML::Emitter& out, const std::vector<std::string>& values) {
  out << YAML::Flow << YAML::BeginSeq;
  for (const std::string& v : values) out << YAML::DoubleQuoted << v;
  out << YAML::EndSeq;
}

void emitReprojection(YAML::Emitter& out, const ReprojectionStats& stats) {
  out << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "blobs" << YAML::Value << stats.blobs;
  out << YAML::Key << "rms_px_before" << YAML::Value << formatDouble(stats.rms_px_before);
  out << YAML::Key << "rms_px_after" << YAML::Value << formatDouble(stats.rms_px_after);
  out << YAML::Key << "after_stage" << YAML::Value << stats.after_stage;
  out << YAML::EndMap;
}

std::string csvPoseRow(const std::string& label, const Rigid3d& pose) {
  const Eigen::Quaterniond q = pose.rotation.normalized();
  std::string row = label;
  for (double v : {pose.translation.x(), pose.translation.y(), pose.translation.z(), q.x(), q.y(),
                   q.z(), q.w()}) {
    row += "," + formatDouble(v);
  }
  return row;
}

// ---- reading ----

struct Reader : YamlReader {
  using YamlReader::YamlReader;

  std::vector<double> numbers(const YAML::Node& node, const std::string& field,
                              size_t expected) const {
    if (!node.IsSequence() || node.size() != expected) {
      throw Error(at(node, field), "expected a list of " + std::to_string(expected) + " numbers");
    }
    std::vector<double> values;
    for (size_t i = 0; i < node.size(); ++i) {
      values.push_back(number(node[i], field + "[" + std::to_string(i) + "]"));
    }
    return values;
  }

  Eigen::Vector3d vector3(const YAML::Node& node, const std::string& field) const {
    const std::vector<double> v = numbers(node, field, 3);
    return Eigen::Vector3d(v[0], v[1], v[2]);
  }

  Rigid3d pose(const YAML::Node& node, const std::string& field) const {
    rejectUnknownKeys(node, {"translation", "rotation_xyzw"}, field);
    const std::vector<double> t =
        numbers(require(node, "translation", field + ".translation"), field + ".translation", 3);
    const std::vector<double> q = numbers(require(node, "rotation_xyzw", field + ".rotation_xyzw"),
                                          field + ".rotation_xyzw", 4);
    Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
    const double norm = rotation.norm();
    if (std::abs(norm - 1.0) > 1e-3) {
      throw Error(at(node, field + ".rotation_xyzw"),
                  "quaternion norm is " + formatFixed(norm, 6) + ", expected 1");
    }
    rotation.normalize();
    return Rigid3d(rotation, Eigen::Vector3d(t[0], t[1], t[2]));
  }

  Matrix6d covariance(const YAML::Node& node, const std::string& field) const {
    const std::vector<double> v = numbers(node, field, 36);
    Matrix6d m;
    for (int r = 0; r < 6; ++r) {
      for (int c = 0; c < 6; ++c) m(r, c) = v[6 * r + c];
    }
    return m;
  }

  std::vector<std::string> strings(const YAML::Node& node, const std::string& field) const {
    if (!node.IsSequence()) throw Error(at(node, field), "expected a list");
    std::vector<std::string> values;
    for (size_t i = 0; i < node.size(); ++i) {
      values.push_back(text(node[i], field + "[" + std::to_string(i) + "]"));
    }
    return values;
  }

  int count(const YAML::Node& node, const std::string& field) const {
    const long long v = integer(node, field);
    if (v < 0) throw Error(at(node, field), "expected a count (>= 0)");
    return static_cast<int>(v);
  }

  ReprojectionStats reprojection(const YAML::Node& node, const std::string& field) const {
    rejectUnknownKeys(node, {"blobs", "rms_px_before", "rms_px_after", "after_stage"}, field);
    ReprojectionStats stats;
    stats.blobs = count(require(node, "blobs", field + ".blobs"), field + ".blobs");
    stats.rms_px_before =
        number(require(node, "rms_px_before", field + ".rms_px_before"), field + ".rms_px_before");
    stats.rms_px_after =
        number(require(node, "rms_px_after", field + ".rms_px_after"), field + ".rms_px_after");
    // Absent in files written before the joint stage computed its own (look_up's then).
    if (node["after_stage"]) {
      stats.after_stage = text(node["after_stage"], field + ".after_stage");
    }
    return stats;
  }
};

CameraRegistration readCamera(const Reader& r, const YAML::Node& node, const std::string& field) {
  r.rejectUnknownKeys(node,
                      {"label", "status", "reason", "world_from_camera", "stages", "covariance",
                       "aligned_position_covariance", "detections", "residuals", "reprojection",
                       "clock_offset", "warnings", "notes"},
                      field);
  CameraRegistration camera;
  camera.label = r.text(r.require(node, "label", field + ".label"), field + ".label");
  const std::string status =
      r.text(r.require(node, "status", field + ".status"), field + ".status");
  const auto parsed = parseCameraStatus(status);
  if (!parsed) {
    throw Error(r.at(node["status"], field + ".status"),
                "unknown status '" + status + "' (registered, suspect, unregistered)");
  }
  camera.status = *parsed;
  if (node["reason"]) camera.reason = r.text(node["reason"], field + ".reason");
  if (node["world_from_camera"]) {
    camera.world_from_camera = r.pose(node["world_from_camera"], field + ".world_from_camera");
  }
  if (const YAML::Node stages = node["stages"]; stages && !stages.IsNull()) {
    if (!stages.IsMap()) throw Error(r.at(stages, field + ".stages"), "expected a mapping");
    for (const auto& entry : stages) {
      const std::string stage = r.key(entry.first, field + ".stages");
      camera.stage_poses[stage] = r.pose(entry.second, field + ".stages." + stage);
    }
  }
  if (node["covariance"])
    camera.covariance = r.covariance(node["covariance"], field + ".covariance");
  if (const YAML::Node a = node["aligned_position_covariance"]; a) {
    const std::vector<double> v = r.numbers(a, field + ".aligned_position_covariance", 9);
    camera.aligned_position_covariance = Eigen::Map<const Eigen::Matrix3d>(v.data()).transpose();
  }
  if (const YAML::Node d = node["detections"]; d) {
    const std::string f = field + ".detections";
    r.rejectUnknownKeys(d, {"total", "used", "rejected", "outside_trajectory"}, f);
    camera.detections.total = r.count(r.require(d, "total", f + ".total"), f + ".total");
    camera.detections.used = r.count(r.require(d, "used", f + ".used"), f + ".used");
    camera.detections.rejected =
        r.count(r.require(d, "rejected", f + ".rejected"), f + ".rejected");
    camera.detections.outside_trajectory = r.count(
        r.require(d, "outside_trajectory", f + ".outside_trajectory"), f + ".outside_trajectory");
  }
  if (const YAML::Node res = node["residuals"]; res) {
    const std::string f = field + ".residuals";
    r.rejectUnknownKeys(res, {"position_rms_m", "rotation_rms_deg"}, f);
    ResidualStats stats;
    stats.position_rms_m =
        r.number(r.require(res, "position_rms_m", f + ".position_rms_m"), f + ".position_rms_m");
    stats.rotation_rms_deg = r.number(r.require(res, "rotation_rms_deg", f + ".rotation_rms_deg"),
                                      f + ".rotation_rms_deg");
    camera.residuals = stats;
  }
  if (node["reprojection"]) {
    camera.reprojection = r.reprojection(node["reprojection"], field + ".reprojection");
  }
  if (const YAML::Node c = node["clock_offset"]; c) {
    const std::string f = field + ".clock_offset";
    r.rejectUnknownKeys(c, {"offset_ns", "sigma_ms", "estimated"}, f);
    ClockOffsetEstimate offset;
    offset.offset_ns = r.integer(r.require(c, "offset_ns", f + ".offset_ns"), f + ".offset_ns");
    offset.sigma_ms = r.number(r.require(c, "sigma_ms", f + ".sigma_ms"), f + ".sigma_ms");
    offset.estimated = r.boolean(r.require(c, "estimated", f + ".estimated"), f + ".estimated");
    camera.clock_offset = offset;
  }
  if (node["warnings"]) camera.warnings = r.strings(node["warnings"], field + ".warnings");
  if (node["notes"]) camera.notes = r.strings(node["notes"], field + ".notes");
  return camera;
}

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

std::vector<BlobAssociation> readBlobAssociations(const std::filesystem::path& path) {
  std::vector<BlobAssociation> rows;
  std::ifstream in(path);
  if (!in) throw Error({path.string(), 0, "", ""}, "cannot be read");
  std::string line;
  int line_number = 0;
  const std::string header = "t_ns,camera,u,v,u_before,v_before,u_after,v_after";
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line_number == 1) {
      if (line != header) {
        throw Error({path.string(), 1, "", ""}, "expected the header '" + header + "'");
      }
      continue;
    }
    if (line.empty()) continue;
    const std::vector<std::string> f = splitCsv(line);
    const ErrorContext where{path.string(), line_number, "", ""};
    if (f.size() != 8) {
      throw Error(where, "expected 8 fields, got " + std::to_string(f.size()));
    }
    BlobAssociation row;
    const auto t = parseInt(f[0]);
    if (!t)
      throw Error({path.string(), line_number, "t_ns", ""}, "'" + f[0] + "' is not an integer");
    row.t = *t;
    row.camera = f[1];
    double* targets[6] = {&row.u, &row.v, &row.u_before, &row.v_before, &row.u_after, &row.v_after};
    const char* names[6] = {"u", "v", "u_before", "v_before", "u_after", "v_after"};
    for (int i = 0; i < 6; ++i) {
      const auto v = parseDouble(f[2 + i]);
      if (!v) {
        throw Error({path.string(), line_number, names[i], ""},
                    "'" + f[2 + i] + "' is not a number");
      }
      *targets[i] = *v;
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

void emitObservability(YAML::Emitter& out, const Observability& o) {
  out << YAML::BeginMap;
  out << YAML::Key << "message" << YAML::Value << YAML::DoubleQuoted << o.message;
  out << YAML::Key << "eigenvalues" << YAML::Value;
  emitNumbers(out, o.eigenvalues.data(), static_cast<int>(o.eigenvalues.size()));
  if (o.aligned_position_rmse_m) {
    out << YAML::Key << "aligned_position_rmse_m" << YAML::Value
        << formatDouble(*o.aligned_position_rmse_m);
  }
  if (const auto& d = o.drift_model) {
    out << YAML::Key << "drift_model" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "horizontal" << YAML::Value << formatDouble(d->horizontal);
    out << YAML::Key << "vertical" << YAML::Value << formatDouble(d->vertical);
    out << YAML::Key << "tilt" << YAML::Value << formatDouble(d->tilt);
    out << YAML::Key << "yaw" << YAML::Value << formatDouble(d->yaw);
    out << YAML::Key << "updates" << YAML::Value << d->updates;
    if (d->between_samples_velocity_walk && d->between_samples_rate_walk) {
      out << YAML::Key << "between_samples_velocity_walk" << YAML::Value
          << formatDouble(*d->between_samples_velocity_walk);
      out << YAML::Key << "between_samples_rate_walk" << YAML::Value
          << formatDouble(*d->between_samples_rate_walk);
    }
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
}

}  // namespace

std::string registrationToYaml(const Registration& reg) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << kFormat;
  out << YAML::Key << "dataset" << YAML::Value << YAML::DoubleQuoted << reg.dataset;
  out << YAML::Key << "created" << YAML::Value << reg.created;
  out << YAML::Key << "versions" << YAML::Value << YAML::Flow << YAML::BeginMap;
  for (const auto& [name, version] : reg.versions) {
    out << YAML::Key << name << YAML::Value << YAML::DoubleQuoted << version;
  }
  out << YAML::EndMap;
  out << YAML::Key << "pipeline" << YAML::Value;
  emitStrings(out, reg.pipeline);

  out << YAML::Key << "trajectory" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "mode" << YAML::Value << trajectoryModeName(reg.trajectory_mode);
  out << YAML::Key << "label" << YAML::Value << YAML::DoubleQuoted << reg.trajectory_label;
  out << YAML::Key << "scale" << YAML::Value << formatDouble(reg.scale);
  out << YAML::Key << "scale_sigma" << YAML::Value << formatDouble(reg.scale_sigma);
  out << YAML::EndMap;

  out << YAML::Key << "world_frame" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << reg.world_frame.name;
  out << YAML::Key << "description" << YAML::Value << YAML::DoubleQuoted
      << reg.world_frame.description;
  if (reg.world_frame.from_registration) {
    out << YAML::Key << "from_registration" << YAML::Value;
    emitPose(out, *reg.world_frame.from_registration);
    if (reg.world_frame.scale_from_registration != 1) {
      out << YAML::Key << "scale_from_registration" << YAML::Value
          << formatDouble(reg.world_frame.scale_from_registration);
    }
  }
  if (!reg.world_frame.control_points.empty()) {
    out << YAML::Key << "control_points" << YAML::Value << YAML::BeginSeq;
    for (const ControlPointFit& p : reg.world_frame.control_points) {
      out << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << p.name;
      out << YAML::Key << "p_in_site" << YAML::Value;
      emitNumbers(out, p.p_in_site.data(), 3);
      out << YAML::Key << "residual_m" << YAML::Value;
      emitNumbers(out, p.residual_m.data(), 3);
      out << YAML::Key << "sigmas" << YAML::Value << formatDouble(p.sigmas);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::EndMap;

  out << YAML::Key << "fisheye_from_marker" << YAML::Value << YAML::BeginMap;
  {
    const Eigen::Quaterniond q = reg.fisheye_from_marker.rotation.normalized();
    const double xyzw[4] = {q.x(), q.y(), q.z(), q.w()};
    out << YAML::Key << "translation" << YAML::Value;
    emitNumbers(out, reg.fisheye_from_marker.translation.data(), 3);
    out << YAML::Key << "rotation_xyzw" << YAML::Value;
    emitNumbers(out, xyzw, 4);
    out << YAML::Key << "covariance" << YAML::Value;
    emitCovariance(out, reg.fisheye_from_marker_covariance);
    out << YAML::Key << "determined" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (bool d : reg.fisheye_from_marker_determined) out << d;
    out << YAML::EndSeq;
    out << YAML::Key << "prior" << YAML::Value << YAML::DoubleQuoted
        << reg.fisheye_from_marker_prior;
  }
  out << YAML::EndMap;

  out << YAML::Key << "cameras" << YAML::Value << YAML::BeginSeq;
  for (const CameraRegistration& c : reg.cameras) {
    out << YAML::BeginMap;
    out << YAML::Key << "label" << YAML::Value << YAML::DoubleQuoted << c.label;
    out << YAML::Key << "status" << YAML::Value << cameraStatusName(c.status);
    out << YAML::Key << "reason" << YAML::Value << YAML::DoubleQuoted << c.reason;
    if (c.status != CameraStatus::kUnregistered) {
      out << YAML::Key << "world_from_camera" << YAML::Value;
      emitPose(out, c.world_from_camera);
    }
    if (!c.stage_poses.empty()) {
      out << YAML::Key << "stages" << YAML::Value << YAML::BeginMap;
      for (const auto& [stage, pose] : c.stage_poses) {
        out << YAML::Key << stage << YAML::Value;
        emitPose(out, pose);
      }
      out << YAML::EndMap;
    }
    if (c.covariance) {
      out << YAML::Key << "covariance" << YAML::Value;
      emitCovariance(out, *c.covariance);
    }
    if (c.aligned_position_covariance) {
      double values[9];
      for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) values[3 * r + k] = (*c.aligned_position_covariance)(r, k);
      }
      out << YAML::Key << "aligned_position_covariance" << YAML::Value;
      emitNumbers(out, values, 9);
    }
    out << YAML::Key << "detections" << YAML::Value << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "total" << YAML::Value << c.detections.total;
    out << YAML::Key << "used" << YAML::Value << c.detections.used;
    out << YAML::Key << "rejected" << YAML::Value << c.detections.rejected;
    out << YAML::Key << "outside_trajectory" << YAML::Value << c.detections.outside_trajectory;
    out << YAML::EndMap;
    if (c.residuals) {
      out << YAML::Key << "residuals" << YAML::Value << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "position_rms_m" << YAML::Value
          << formatDouble(c.residuals->position_rms_m);
      out << YAML::Key << "rotation_rms_deg" << YAML::Value
          << formatDouble(c.residuals->rotation_rms_deg);
      out << YAML::EndMap;
    }
    if (c.reprojection) {
      out << YAML::Key << "reprojection" << YAML::Value;
      emitReprojection(out, *c.reprojection);
    }
    if (c.clock_offset) {
      out << YAML::Key << "clock_offset" << YAML::Value << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "offset_ns" << YAML::Value << c.clock_offset->offset_ns;
      out << YAML::Key << "sigma_ms" << YAML::Value << formatDouble(c.clock_offset->sigma_ms);
      out << YAML::Key << "estimated" << YAML::Value << c.clock_offset->estimated;
      out << YAML::EndMap;
    }
    out << YAML::Key << "warnings" << YAML::Value;
    emitStrings(out, c.warnings);
    if (!c.notes.empty()) {
      out << YAML::Key << "notes" << YAML::Value;
      emitStrings(out, c.notes);
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  if (reg.reprojection) {
    out << YAML::Key << "reprojection" << YAML::Value;
    emitReprojection(out, *reg.reprojection);
  }
  out << YAML::Key << "observability" << YAML::Value;
  emitObservability(out, reg.observability);
  out << YAML::Key << "warnings" << YAML::Value;
  emitStrings(out, reg.warnings);
  out << YAML::Key << "notes" << YAML::Value;
  emitStrings(out, reg.notes);

  const RegistrationStatistics& s = reg.statistics;
  out << YAML::Key << "statistics" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "detections_total" << YAML::Value
      << static_cast<long long>(s.detections_total);
  out << YAML::Key << "detections_associated" << YAML::Value
      << static_cast<long long>(s.detections_associated);
  out << YAML::Key << "dropped_outside_trajectory" << YAML::Value
      << static_cast<long long>(s.dropped_outside_trajectory);
  out << YAML::Key << "dropped_gap" << YAML::Value << static_cast<long long>(s.dropped_gap);
  out << YAML::Key << "seconds_per_stage" << YAML::Value << YAML::Flow << YAML::BeginMap;
  for (const auto& [stage, seconds] : s.seconds_per_stage) {
    out << YAML::Key << stage << YAML::Value << formatDouble(seconds);
  }
  out << YAML::EndMap;
  if (!s.seconds_per_step.empty()) {
    out << YAML::Key << "seconds_per_step" << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (const auto& [step, seconds] : s.seconds_per_step) {
      out << YAML::Key << step << YAML::Value << formatDouble(seconds);
    }
    out << YAML::EndMap;
  }
  if (s.drive_seconds > 0) {
    out << YAML::Key << "drive_seconds" << YAML::Value << formatDouble(s.drive_seconds);
  }
  out << YAML::EndMap;

  out << YAML::Key << "config" << YAML::Value;
  if (reg.config_yaml.empty()) {
    out << YAML::Flow << YAML::BeginMap << YAML::EndMap;
  } else {
    out << YAML::Load(reg.config_yaml);
  }
  out << YAML::EndMap;
  return std::string("# lookboth registration (doc/formats.md, \"Registration output\")\n") +
         out.c_str() + "\n";
}

void saveRegistration(const Registration& reg, const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error({dir.string(), 0, "", ""}, "cannot create the directory: " + ec.message());

  {
    AtomicOutputFile file(dir / "cameras.csv");
    file.stream() << "label,tx,ty,tz,qx,qy,qz,qw\n";
    for (const CameraRegistration& c : reg.cameras) {
      if (c.status == CameraStatus::kUnregistered) continue;
      file.stream() << csvPoseRow(c.label, c.world_from_camera) << "\n";
    }
    file.commit();
  }
  writeFileAtomically(dir / "registration.yaml", registrationToYaml(reg));
  {
    Trajectory trajectory;
    for (const StampedPose& p : reg.trajectory) trajectory.append(p.t, p.world_from_body);
    writeTumFile(dir / "trajectory.tum", trajectory);
  }
  {
    AtomicOutputFile file(dir / "blob_associations.csv");
    file.stream() << "t_ns,camera,u,v,u_before,v_before,u_after,v_after\n";
    for (const BlobAssociation& b : reg.blob_associations) {
      file.stream() << b.t << "," << b.camera;
      for (double v : {b.u, b.v, b.u_before, b.v_before, b.u_after, b.v_after}) {
        file.stream() << "," << formatDouble(v);
      }
      file.stream() << "\n";
    }
    file.commit();
  }
}

Registration loadRegistration(const std::filesystem::path& dir,
                              const RegistrationLoadOptions& options) {
  const std::filesystem::path yaml_path = dir / "registration.yaml";
  const Reader r(yaml_path.string());
  const YAML::Node root = r.parse(readFile(yaml_path));
  if (!root.IsMap()) throw Error({yaml_path.string(), 0, "", ""}, "expected a YAML mapping");
  r.rejectUnknownKeys(root,
                      {"format", "dataset", "created", "versions", "pipeline", "trajectory",
                       "world_frame", "fisheye_from_marker", "cameras", "reprojection",
                       "observability", "warnings", "notes", "statistics", "config"},
                      "");
  const std::string format = r.text(r.require(root, "format", "format"), "format");
  if (format != kFormat) {
    throw Error(r.at(root["format"], "format"),
                "'" + format + "' is not supported (this lookboth reads '" + kFormat + "')");
  }
  Registration reg;
  reg.dataset = r.text(r.require(root, "dataset", "dataset"), "dataset");
  if (root["created"]) reg.created = r.text(root["created"], "created");
  if (const YAML::Node versions = root["versions"]; versions && !versions.IsNull()) {
    if (!versions.IsMap()) throw Error(r.at(versions, "versions"), "expected a mapping");
    for (const auto& entry : versions) {
      const std::string name = r.key(entry.first, "versions");
      reg.versions[name] = r.text(entry.second, "versions." + name);
    }
  }
  reg.pipeline = r.strings(r.require(root, "pipeline", "pipeline"), "pipeline");

  {
    const YAML::Node t = r.require(root, "trajectory", "trajectory");
    r.rejectUnknownKeys(t, {"mode", "label", "scale", "scale_sigma"}, "trajectory");
    const std::string mode = r.text(r.require(t, "mode", "trajectory.mode"), "trajectory.mode");
    const auto parsed = parseTrajectoryMode(mode);
    if (!parsed) {
      throw Error(r.at(t["mode"], "trajectory.mode"),
                  "unknown mode '" + mode + "' (visual, metric)");
    }
    reg.trajectory_mode = *parsed;
    if (t["label"]) reg.trajectory_label = r.text(t["label"], "trajectory.label");
    reg.scale = r.number(r.require(t, "scale", "trajectory.scale"), "trajectory.scale");
    if (t["scale_sigma"]) reg.scale_sigma = r.number(t["scale_sigma"], "trajectory.scale_sigma");
  }

  if (const YAML::Node w = root["world_frame"]; w) {
    r.rejectUnknownKeys(
        w,
        {"name", "description", "from_registration", "scale_from_registration", "control_points"},
        "world_frame");
    if (w["scale_from_registration"]) {
      reg.world_frame.scale_from_registration =
          r.number(w["scale_from_registration"], "world_frame.scale_from_registration");
      if (!(reg.world_frame.scale_from_registration > 0)) {
        throw Error(r.at(w["scale_from_registration"], "world_frame.scale_from_registration"),
                    "must be positive");
      }
    }
    reg.world_frame.name = r.text(r.require(w, "name", "world_frame.name"), "world_frame.name");
    if (w["description"]) {
      reg.world_frame.description = r.text(w["description"], "world_frame.description");
    }
    if (w["from_registration"]) {
      reg.world_frame.from_registration =
          r.pose(w["from_registration"], "world_frame.from_registration");
    }
    if (const YAML::Node points = w["control_points"]; points) {
      if (!points.IsSequence())
        throw Error(r.at(points, "world_frame.control_points"), "expected a list");
      for (std::size_t i = 0; i < points.size(); ++i) {
        const std::string f = "world_frame.control_points[" + std::to_string(i) + "]";
        const YAML::Node p = points[i];
        r.rejectUnknownKeys(p, {"name", "p_in_site", "residual_m", "sigmas"}, f);
        ControlPointFit fit;
        fit.name = r.text(r.require(p, "name", f + ".name"), f + ".name");
        fit.p_in_site = r.vector3(r.require(p, "p_in_site", f + ".p_in_site"), f + ".p_in_site");
        fit.residual_m =
            r.vector3(r.require(p, "residual_m", f + ".residual_m"), f + ".residual_m");
        fit.sigmas = r.number(r.require(p, "sigmas", f + ".sigmas"), f + ".sigmas");
        reg.world_frame.control_points.push_back(fit);
      }
    }
  }

  {
    const std::string f = "fisheye_from_marker";
    const YAML::Node m = r.require(root, "fisheye_from_marker", f);
    r.rejectUnknownKeys(m, {"translation", "rotation_xyzw", "covariance", "determined", "prior"},
                        f);
    const std::vector<double> t =
        r.numbers(r.require(m, "translation", f + ".translation"), f + ".translation", 3);
    const std::vector<double> q =
        r.numbers(r.require(m, "rotation_xyzw", f + ".rotation_xyzw"), f + ".rotation_xyzw", 4);
    Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
    if (std::abs(rotation.norm() - 1.0) > 1e-3) {
      throw Error(r.at(m["rotation_xyzw"], f + ".rotation_xyzw"), "quaternion norm is not 1");
    }
    reg.fisheye_from_marker = Rigid3d(rotation.normalized(), Eigen::Vector3d(t[0], t[1], t[2]));
    if (m["covariance"]) {
      reg.fisheye_from_marker_covariance = r.covariance(m["covariance"], f + ".covariance");
    }
    if (const YAML::Node d = m["determined"]; d) {
      if (!d.IsSequence() || d.size() != 6) {
        throw Error(r.at(d, f + ".determined"), "expected a list of 6 booleans");
      }
      for (size_t i = 0; i < 6; ++i) {
        reg.fisheye_from_marker_determined[i] =
            r.boolean(d[i], f + ".determined[" + std::to_string(i) + "]");
      }
    }
    if (m["prior"]) reg.fisheye_from_marker_prior = r.text(m["prior"], f + ".prior");
  }

  if (const YAML::Node cameras = root["cameras"]; cameras && !cameras.IsNull()) {
    if (!cameras.IsSequence()) throw Error(r.at(cameras, "cameras"), "expected a list");
    for (size_t i = 0; i < cameras.size(); ++i) {
      reg.cameras.push_back(readCamera(r, cameras[i], "cameras[" + std::to_string(i) + "]"));
    }
  }
  if (root["reprojection"]) reg.reprojection = r.reprojection(root["reprojection"], "reprojection");
  if (const YAML::Node o = root["observability"]; o) {
    r.rejectUnknownKeys(o, {"message", "eigenvalues", "aligned_position_rmse_m", "drift_model"},
                        "observability");
    if (const YAML::Node d = o["drift_model"]; d) {
      r.rejectUnknownKeys(d,
                          {"horizontal", "vertical", "tilt", "yaw", "updates",
                           "between_samples_velocity_walk", "between_samples_rate_walk"},
                          "observability.drift_model");
      DriftModelEstimate e;
      const std::string at = "observability.drift_model.";
      for (const auto& [key, target] :
           std::initializer_list<std::pair<const char*, double*>>{{"horizontal", &e.horizontal},
                                                                  {"vertical", &e.vertical},
                                                                  {"tilt", &e.tilt},
                                                                  {"yaw", &e.yaw}}) {
        *target = r.number(r.require(d, key, at + key), at + key);
      }
      if (d["updates"]) e.updates = r.int32(d["updates"], at + "updates");
      for (const auto& [key, target] :
           std::initializer_list<std::pair<const char*, std::optional<double>*>>{
               {"between_samples_velocity_walk", &e.between_samples_velocity_walk},
               {"between_samples_rate_walk", &e.between_samples_rate_walk}}) {
        if (d[key]) *target = r.number(d[key], at + key);
      }
      reg.observability.drift_model = e;
    }
    if (o["aligned_position_rmse_m"]) {
      reg.observability.aligned_position_rmse_m =
          r.number(o["aligned_position_rmse_m"], "observability.aligned_position_rmse_m");
    }
    if (o["message"]) reg.observability.message = r.text(o["message"], "observability.message");
    if (const YAML::Node e = o["eigenvalues"]; e) {
      reg.observability.eigenvalues = r.numbers(e, "observability.eigenvalues", e.size());
    }
  }
  if (root["warnings"]) reg.warnings = r.strings(root["warnings"], "warnings");
  if (root["notes"]) reg.notes = r.strings(root["notes"], "notes");
  if (const YAML::Node s = root["statistics"]; s) {
    r.rejectUnknownKeys(s,
                        {"detections_total", "detections_associated", "dropped_outside_trajectory",
                         "dropped_gap", "seconds_per_stage", "seconds_per_step", "drive_seconds"},
                        "statistics");
    auto integer = [&](const char* key, std::int64_t& target) {
      if (s[key]) target = r.integer(s[key], std::string("statistics.") + key);
    };
    integer("detections_total", reg.statistics.detections_total);
    integer("detections_associated", reg.statistics.detections_associated);
    integer("dropped_outside_trajectory", reg.statistics.dropped_outside_trajectory);
    integer("dropped_gap", reg.statistics.dropped_gap);
    for (const char* field : {"seconds_per_stage", "seconds_per_step"}) {
      const YAML::Node seconds = s[field];
      if (!seconds || seconds.IsNull()) continue;
      const std::string at = std::string("statistics.") + field;
      if (!seconds.IsMap()) throw Error(r.at(seconds, at), "expected a mapping");
      auto& target = std::string(field) == "seconds_per_stage" ? reg.statistics.seconds_per_stage
                                                               : reg.statistics.seconds_per_step;
      for (const auto& entry : seconds) {
        const std::string name = r.key(entry.first, at);
        target[name] = r.number(entry.second, at + "." + name);
      }
    }
    if (s["drive_seconds"]) {
      reg.statistics.drive_seconds = r.number(s["drive_seconds"], "statistics.drive_seconds");
    }
  }
  if (const YAML::Node config = root["config"]; config && !config.IsNull()) {
    YAML::Emitter text;
    text << config;
    reg.config_yaml = text.c_str();
  }

  const std::filesystem::path tum = dir / "trajectory.tum";
  if (std::filesystem::exists(tum)) reg.trajectory = readTumFile(tum).samples();
  const std::filesystem::path blobs = dir / "blob_associations.csv";
  if (options.blob_associations && std::filesystem::exists(blobs)) {
    reg.blob_associations = readBlobAssociations(blobs);
  }
  return reg;
}

}  // namespace lookboth
