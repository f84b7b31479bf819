#include "lookboth/report/pose_comparison.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/umeyama.h"

namespace lookboth::report {
namespace fs = std::filesystem;

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

std::string trim(const std::string& text) {
  const size_t begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const size_t end = text.find_last_not_of(" \t\r\n");
  return text.substr(begin, end - begin + 1);
}

std::vector<std::string> splitCommas(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(trim(field));
  if (!line.empty() && line.back() == ',') fields.push_back("");
  return fields;
}

}  // namespace

CameraPoseSet readCamerasCsv(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw Error({path.string(), 0, "", ""}, "cannot open for reading");
  CameraPoseSet set;
  set.source = path.string();
  const std::vector<std::string> required = {"label", "tx", "ty", "tz", "qx", "qy", "qz", "qw"};
  std::map<std::string, size_t> column;
  std::string line;
  int line_number = 0;
  bool have_header = false;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string text = trim(line);
    if (text.empty() || text[0] == '#') continue;
    const std::vector<std::string> fields = splitCommas(text);
    if (!have_header) {
      for (size_t i = 0; i < fields.size(); ++i) column[fields[i]] = i;
      for (const std::string& name : required) {
        if (!column.count(name)) {
          throw Error({path.string(), line_number, name, ""},
                      "required column is missing from the header (expected "
                      "'label,tx,ty,tz,qx,qy,qz,qw')");
        }
      }
      have_header = true;
      continue;
    }
    if (fields.size() < column.size()) {
      std::string first_missing;
      for (const auto& [name, index] : column) {
        if (index == fields.size()) first_missing = name;
      }
      throw Error({path.string(), line_number, first_missing, ""},
                  "the row has " + std::to_string(fields.size()) + " fields, the header " +
                      std::to_string(column.size()));
    }
    const auto field = [&](const std::string& name) -> const std::string& {
      return fields[column.at(name)];
    };
    const std::string label = field("label");
    if (label.empty()) throw Error({path.string(), line_number, "label", ""}, "empty label");
    const auto number = [&](const std::string& name) {
      const std::string& value = field(name);
      const std::optional<double> parsed = parseDouble(value);
      if (!parsed) {
        throw Error({path.string(), line_number, name, label}, "not a number: '" + value + "'");
      }
      if (!std::isfinite(*parsed)) {
        throw Error({path.string(), line_number, name, label}, "'" + value + "' is not finite");
      }
      return *parsed;
    };
    const Eigen::Vector3d translation(number("tx"), number("ty"), number("tz"));
    Eigen::Quaterniond rotation(number("qw"), number("qx"), number("qy"), number("qz"));
    const double norm = rotation.norm();
    if (std::abs(norm - 1.0) > 1e-3) {
      throw Error({path.string(), line_number, "qx,qy,qz,qw", label},
                  "quaternion (qx qy qz qw) has norm " + formatFixed(norm, 6) +
                      ", expected a unit quaternion");
    }
    rotation.normalize();
    if (!set.world_from_camera.emplace(label, Rigid3d(rotation, translation)).second) {
      throw Error({path.string(), line_number, "label", label}, "camera listed twice");
    }
  }
  if (!have_header) {
    throw Error({path.string(), 0, "", ""},
                "no header line (expected 'label,tx,ty,tz,qx,qy,qz,qw')");
  }
  return set;
}

CameraPoseSet loadGroundTruthPoses(const fs::path& path) {
  if (!fs::exists(path)) throw Error({path.string(), 0, "", ""}, "no such file or folder");
  if (fs::is_regular_file(path) && path.extension() == ".csv") return readCamerasCsv(path);
  DatasetReadOptions read_options;
  read_options.check_images = false;
  const std::unique_ptr<DatasetReader> reader = DatasetReader::open(path, read_options);
  CameraPoseSet set;
  set.source = path.string();
  set.world_from_camera = reader->manifest().ground_truth.world_from_camera;
  if (set.world_from_camera.empty()) {
    throw Error({path.string(), 0, "ground_truth.world_from_camera", ""},
                "the dataset has no ground truth camera poses");
  }
  for (const CameraSensor& sensor : reader->manifest().cameras) {
    if (sensor.role == SensorRole::kEnvCamera && !set.world_from_camera.count(sensor.label)) {
      set.without_pose.push_back(sensor.label);
    }
  }
  return set;
}

namespace {

/// PoseComparison::position_nees_per_dof of a comparison whose alignment and
/// differences are made.
std::optional<double> positionNeesPerDof(const PoseComparison& comparison,
                                         const CameraPoseSet& reference,
                                         const CameraPoseSet& estimate) {
  // Against another registration the reference's own error would count too.
  if (comparison.with_scale || comparison.cameras.empty() ||
      !reference.aligned_position_covariance.empty())
    return std::nullopt;
  const Eigen::Matrix3d turn = comparison.reference_from_estimate.rotation.toRotationMatrix();
  double sum = 0;
  for (const CameraDifference& d : comparison.cameras) {
    const auto found = estimate.aligned_position_covariance.find(d.label);
    if (found == estimate.aligned_position_covariance.end()) return std::nullopt;
    const Eigen::Matrix3d covariance = turn * found->second * turn.transpose();
    const Eigen::LDLT<Eigen::Matrix3d> factor(covariance);
    if (factor.info() != Eigen::Success || !(factor.vectorD().array() > 0).all())
      return std::nullopt;
    sum += d.position_m.dot(factor.solve(d.position_m));
  }
  return sum / (3.0 * static_cast<double>(comparison.cameras.size()));
}

}  // namespace

PoseComparison comparePoses(const CameraPoseSet& reference, const CameraPoseSet& estimate,
                            const CompareOptions& options) {
  PoseComparison result;
  result.reference_source = reference.source;
  result.estimate_source = estimate.source;
  result.with_scale = options.with_scale;

  std::vector<std::string> common;
  std::vector<Rigid3d> reference_poses, estimate_poses;
  for (const auto& [label, pose] : reference.world_from_camera) {
    const auto found = estimate.world_from_camera.find(label);
    if (found == estimate.world_from_camera.end()) {
      result.missing_in_estimate.push_back(label);
      continue;
    }
    common.push_back(label);
    reference_poses.push_back(pose);
    estimate_poses.push_back(found->second);
  }
  for (const std::string& label : reference.without_pose) {
    if (!estimate.world_from_camera.count(label)) result.missing_in_estimate.push_back(label);
  }
  std::sort(result.missing_in_estimate.begin(), result.missing_in_estimate.end());
  result.missing_in_estimate.erase(
      std::unique(result.missing_in_estimate.begin(), result.missing_in_estimate.end()),
      result.missing_in_estimate.end());
  for (const auto& [label, pose] : estimate.world_from_camera) {
    if (!reference.world_from_camera.count(label)) result.missing_in_reference.push_back(label);
  }

  std::string why_not;
  const std::optional<AlignmentResult> alignment =
      alignPoses(estimate_poses, reference_poses, options.with_scale, &why_not);
  if (!alignment) {
    throw Error("cannot align " + estimate.source + " onto " + reference.source + " over " +
                std::to_string(common.size()) + " common camera(s): " + why_not);
  }
  result.reference_from_estimate = alignment->dst_from_src;

  double sum_position = 0, sum_rotation = 0;
  Eigen::Vector3d sum_axes_position = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_axes_rotation = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < common.size(); ++i) {
    const Rigid3d aligned = result.reference_from_estimate.transformPose(estimate_poses[i]);
    CameraDifference d;
    d.label = common[i];
    d.position_m = aligned.translation - reference_poses[i].translation;
    d.position_error_m = d.position_m.norm();
    const Eigen::Quaterniond delta = aligned.rotation * reference_poses[i].rotation.conjugate();
    d.roll_pitch_yaw_deg = rollPitchYaw(delta.normalized().toRotationMatrix()) * kRadToDeg;
    d.rotation_error_deg =
        rotationAngleBetween(reference_poses[i].rotation, aligned.rotation) * kRadToDeg;
    sum_position += d.position_error_m * d.position_error_m;
    sum_rotation += d.rotation_error_deg * d.rotation_error_deg;
    sum_axes_position += d.position_m.cwiseAbs2();
    sum_axes_rotation += d.roll_pitch_yaw_deg.cwiseAbs2();
    result.rms.position_m_max = std::max(result.rms.position_m_max, d.position_error_m);
    result.rms.rotation_deg_max = std::max(result.rms.rotation_deg_max, d.rotation_error_deg);
    result.cameras.push_back(d);
  }
  const double n = static_cast<double>(common.size());
  result.position_nees_per_dof = positionNeesPerDof(result, reference, estimate);
  result.rms.position_m_total = std::sqrt(sum_position / n);
  result.rms.rotation_deg_total = std::sqrt(sum_rotation / n);
  result.rms.position_m = (sum_axes_position / n).cwiseSqrt();
  result.rms.roll_pitch_yaw_deg = (sum_axes_rotation / n).cwiseSqrt();
  return result;
}

ReprojectionTable reprojectionTable(const std::vector<ReprojectionRow>& rows) {
  ReprojectionTable table;
  std::map<std::string, std::pair<double, double>> sums;  // squared before, after
  double total_before = 0, total_after = 0;
  const auto add = [](ReprojectionSummary& stats, double& sum_before, double& sum_after,
                      const ReprojectionRow& row) {
    ++stats.blobs;
    const Eigen::Vector2d observed(row.u, row.v);
    if (row.before) {
      const double e = (observed - *row.before).norm();
      ++stats.blobs_before;
      sum_before += e * e;
      stats.max_px_before = std::max(stats.max_px_before, e);
    }
    if (row.after) {
      const double e = (observed - *row.after).norm();
      ++stats.blobs_after;
      sum_after += e * e;
      stats.max_px_after = std::max(stats.max_px_after, e);
    }
  };
  for (const ReprojectionRow& row : rows) {
    add(table.total, total_before, total_after, row);
    auto& [before, after] = sums[row.camera];
    add(table.by_camera[row.camera], before, after, row);
  }
  const auto finish = [](ReprojectionSummary& stats, double sum_before, double sum_after) {
    stats.rms_px_before = stats.blobs_before ? std::sqrt(sum_before / stats.blobs_before) : 0.0;
    stats.rms_px_after = stats.blobs_after ? std::sqrt(sum_after / stats.blobs_after) : 0.0;
  };
  finish(table.total, total_before, total_after);
  for (auto& [camera, stats] : table.by_camera) {
    finish(stats, sums[camera].first, sums[camera].second);
  }
  return table;
}

namespace {

// Named fields, as every lookboth JSON/YAML output (doc/conventions.md).
nlohmann::json vectorJson(const Eigen::Vector3d& v) {
  return {{"x", v.x()}, {"y", v.y()}, {"z", v.z()}};
}

nlohmann::json anglesJson(const Eigen::Vector3d& roll_pitch_yaw) {
  return {{"roll", roll_pitch_yaw.x()}, {"pitch", roll_pitch_yaw.y()}, {"yaw", roll_pitch_yaw.z()}};
}

nlohmann::json comparisonJson(const PoseComparison& c) {
  nlohmann::json j;
  j["reference"] = c.reference_source;
  j["estimate"] = c.estimate_source;
  const Sim3d& t = c.reference_from_estimate;
  j["alignment"] = {
      {"type", c.with_scale ? "Sim3" : "SE3"},
      {"scale", t.scale},
      {"rotation_xyzw", {t.rotation.x(), t.rotation.y(), t.rotation.z(), t.rotation.w()}},
      {"translation", vectorJson(t.translation)},
      {"cameras_used", c.cameras.size()}};
  nlohmann::json cameras = nlohmann::json::array();
  for (const CameraDifference& d : c.cameras) {
    cameras.push_back({{"label", d.label},
                       {"position_error_m", d.position_error_m},
                       {"rotation_error_deg", d.rotation_error_deg},
                       {"position_difference_m", vectorJson(d.position_m)},
                       {"rotation_difference_deg", anglesJson(d.roll_pitch_yaw_deg)}});
  }
  j["cameras"] = cameras;
  j["rms"] = {{"position_m", c.rms.position_m_total},
              {"rotation_deg", c.rms.rotation_deg_total},
              {"x_m", c.rms.position_m.x()},
              {"y_m", c.rms.position_m.y()},
              {"z_m", c.rms.position_m.z()},
              {"roll_deg", c.rms.roll_pitch_yaw_deg.x()},
              {"pitch_deg", c.rms.roll_pitch_yaw_deg.y()},
              {"yaw_deg", c.rms.roll_pitch_yaw_deg.z()}};
  j["max"] = {{"position_m", c.rms.position_m_max}, {"rotation_deg", c.rms.rotation_deg_max}};
  if (c.position_nees_per_dof) j["position_nees_per_dof"] = *c.position_nees_per_dof;
  j["missing_in_estimate"] = c.missing_in_estimate;
  j["missing_in_reference"] = c.missing_in_reference;
  return j;
}

nlohmann::json statsJson(const ReprojectionSummary& s) {
  return {{"blobs", s.blobs},
          {"blobs_before", s.blobs_before},
          {"blobs_after", s.blobs_after},
          {"rms_px_before", s.rms_px_before},
          {"rms_px_after", s.rms_px_after},
          {"max_px_before", s.max_px_before},
          {"max_px_after", s.max_px_after}};
}

/// Fixed notation without "-0.000" for values that round to zero.
std::string fixed(double value, int decimals) {
  if (std::abs(value) < 0.5 * std::pow(10.0, -decimals)) value = 0.0;
  return formatFixed(value, decimals);
}

std::string pad(const std::string& text, size_t width) {
  return text.size() >= width ? text : std::string(width - text.size(), ' ') + text;
}

std::string padRight(const std::string& text, size_t width) {
  return text.size() >= width ? text : text + std::string(width - text.size(), ' ');
}

}  // namespace

std::string evaluationToJson(const Evaluation& e) {
  nlohmann::json j;
  j["format"] = "lookboth-evaluation 1";
  j["registration"] = e.registration;
  if (e.ground_truth) j["ground_truth"] = comparisonJson(*e.ground_truth);
  if (e.against) j["against"] = comparisonJson(*e.against);
  if (e.reprojection) {
    nlohmann::json r = statsJson(e.reprojection->total);
    nlohmann::json cameras = nlohmann::json::object();
    for (const auto& [camera, stats] : e.reprojection->by_camera)
      cameras[camera] = statsJson(stats);
    r["cameras"] = cameras;
    if (e.reported_reprojection)
      r["reported_by_registration"] = statsJson(*e.reported_reprojection);
    j["reprojection"] = r;
  }
  return j.dump(2) + "\n";
}

void writeEvaluationJson(const Evaluation& evaluation, const fs::path& path) {
  writeFileAtomically(path, evaluationToJson(evaluation));
}

std::string formatComparisonTable(const PoseComparison& c, const std::string& title) {
  std::ostringstream out;
  out << title << "\n";
  out << "  reference: " << c.reference_source << "\n";
  out << "  estimate:  " << c.estimate_source << "\n";
  out << "  alignment: " << (c.with_scale ? "Sim(3)" : "SE(3)") << " over " << c.cameras.size()
      << " cameras";
  if (c.with_scale) out << ", scale " << fixed(c.reference_from_estimate.scale, 6);
  out << "\n";
  out << "  " << padRight("camera", 12) << pad("pos [m]", 10) << pad("rot [deg]", 11)
      << pad("dx [m]", 10) << pad("dy [m]", 10) << pad("dz [m]", 10) << pad("roll", 9)
      << pad("pitch", 9) << pad("yaw", 9) << "\n";
  for (const CameraDifference& d : c.cameras) {
    out << "  " << padRight(d.label, 12) << pad(fixed(d.position_error_m, 4), 10)
        << pad(fixed(d.rotation_error_deg, 3), 11) << pad(fixed(d.position_m.x(), 4), 10)
        << pad(fixed(d.position_m.y(), 4), 10) << pad(fixed(d.position_m.z(), 4), 10)
        << pad(fixed(d.roll_pitch_yaw_deg.x(), 3), 9) << pad(fixed(d.roll_pitch_yaw_deg.y(), 3), 9)
        << pad(fixed(d.roll_pitch_yaw_deg.z(), 3), 9) << "\n";
  }
  out << "  " << padRight("RMS", 12) << pad(fixed(c.rms.position_m_total, 4), 10)
      << pad(fixed(c.rms.rotation_deg_total, 3), 11) << pad(fixed(c.rms.position_m.x(), 4), 10)
      << pad(fixed(c.rms.position_m.y(), 4), 10) << pad(fixed(c.rms.position_m.z(), 4), 10)
      << pad(fixed(c.rms.roll_pitch_yaw_deg.x(), 3), 9)
      << pad(fixed(c.rms.roll_pitch_yaw_deg.y(), 3), 9)
      << pad(fixed(c.rms.roll_pitch_yaw_deg.z(), 3), 9) << "\n";
  out << "  " << padRight("max", 12) << pad(fixed(c.rms.position_m_max, 4), 10)
      << pad(fixed(c.rms.rotation_deg_max, 3), 11) << "\n";
  if (c.position_nees_per_dof) {
    out << "  position NEES per degree of freedom " << fixed(*c.position_nees_per_dof, 2)
        << " (near 1 when the registration's predicted uncertainty is honest)\n";
  }
  if (!c.missing_in_estimate.empty()) {
    out << "  not registered (not counted):";
    for (const std::string& label : c.missing_in_estimate) out << " " << label;
    out << "\n";
  }
  if (!c.missing_in_reference.empty()) {
    out << "  not in the reference (not counted):";
    for (const std::string& label : c.missing_in_reference) out << " " << label;
    out << "\n";
  }
  return out.str();
}

std::string formatTableTwoRow(const PoseComparison& c, const std::string& row_name) {
  std::ostringstream out;
  const size_t name_width = std::max<size_t>(24, row_name.size() + 2);
  out << "  " << padRight("", name_width) << pad("roll [deg]", 11) << pad("pitch [deg]", 12)
      << pad("yaw [deg]", 11) << pad("X [m]", 9) << pad("Y [m]", 9) << pad("Z [m]", 9) << "\n";
  out << "  " << padRight(row_name, name_width) << pad(fixed(c.rms.roll_pitch_yaw_deg.x(), 4), 11)
      << pad(fixed(c.rms.roll_pitch_yaw_deg.y(), 4), 12)
      << pad(fixed(c.rms.roll_pitch_yaw_deg.z(), 4), 11) << pad(fixed(c.rms.position_m.x(), 4), 9)
      << pad(fixed(c.rms.position_m.y(), 4), 9) << pad(fixed(c.rms.position_m.z(), 4), 9) << "\n";
  return out.str();
}

std::string formatReprojectionTable(const ReprojectionTable& table) {
  std::ostringstream out;
  out << "  " << padRight("camera", 12) << pad("blobs", 7) << pad("RMSE before [px]", 18)
      << pad("RMSE after [px]", 17) << "\n";
  const auto row = [&](const std::string& name, const ReprojectionSummary& s) {
    out << "  " << padRight(name, 12) << pad(std::to_string(s.blobs), 7)
        << pad(s.blobs_before ? fixed(s.rms_px_before, 3) : "-", 18)
        << pad(s.blobs_after ? fixed(s.rms_px_after, 3) : "-", 17) << "\n";
  };
  for (const auto& [camera, stats] : table.by_camera) row(camera, stats);
  row("all", table.total);
  return out.str();
}

}  // namespace lookboth::report
