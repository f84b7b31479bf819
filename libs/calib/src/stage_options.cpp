// Options of the paper's stages: reading from a configuration section (each
// layer sets the keys it has; unknown keys are errors) and checks.
#include <cmath>

#include "lookboth/calib/builtin_stages.h"
#include "lookboth/core/text.h"
#include "lookboth/solver/fill_reducing_ordering.h"

namespace lookboth {
namespace {

// Sets `target` from node[key] when present.
struct Section {
  const YamlReader& r;
  const YAML::Node& node;
  const std::string& field;

  std::string path(const char* key) const { return field + "." + key; }
  void number(const char* key, double& target) const {
    if (node[key]) target = r.number(node[key], path(key));
  }
  void integer(const char* key, int& target) const {
    if (node[key]) target = r.int32(node[key], path(key));
  }
  void vector3(const char* key, Eigen::Vector3d& target) const {
    const YAML::Node n = node[key];
    if (!n) return;
    if (!n.IsSequence() || n.size() != 3) throw Error(r.at(n, path(key)), "expected [x, y, z]");
    for (int i = 0; i < 3; ++i) target[i] = r.number(n[i], path(key));
  }
  void optionalVector3(const char* key, std::optional<Eigen::Vector3d>& target) const {
    const YAML::Node n = node[key];
    if (!n) return;
    if (n.IsNull()) {
      target.reset();
      return;
    }
    Eigen::Vector3d v;
    vector3(key, v);
    target = v;
  }
  void optionalQuaternion(const char* key, std::optional<Eigen::Quaterniond>& target) const {
    const YAML::Node n = node[key];
    if (!n) return;
    if (n.IsNull()) {
      target.reset();
      return;
    }
    if (!n.IsSequence() || n.size() != 4) {
      throw Error(r.at(n, path(key)), "expected [qx, qy, qz, qw]");
    }
    double v[4];
    for (int i = 0; i < 4; ++i) v[i] = r.number(n[i], path(key));
    Eigen::Quaterniond q(v[3], v[0], v[1], v[2]);
    if (std::abs(q.norm() - 1.0) > 1e-3)
      throw Error(r.at(n, path(key)), "quaternion norm is not 1");
    target = q.normalized();
  }
};

std::string positive(const char* name, double value) {
  if (!(value > 0) || !std::isfinite(value)) {
    return std::string("'") + name + "': must be positive, got " + formatDouble(value);
  }
  return "";
}

}  // namespace

void AssociateOptions::read(const YamlReader& r, const YAML::Node& node, const std::string& field) {
  r.rejectUnknownKeys(node, {"max_gap_s", "clock_offsets_ns"}, field);
  const Section s{r, node, field};
  s.number("max_gap_s", max_gap_s);
  if (const YAML::Node offsets = node["clock_offsets_ns"]; offsets && !offsets.IsNull()) {
    if (!offsets.IsMap()) {
      throw Error(r.at(offsets, field + ".clock_offsets_ns"), "expected a mapping label: ns");
    }
    for (const auto& entry : offsets) {
      const std::string label = r.key(entry.first, field + ".clock_offsets_ns");
      clock_offsets_ns[label] = r.integer(entry.second, field + ".clock_offsets_ns." + label);
    }
  }
}

std::string AssociateOptions::check() const { return positive("max_gap_s", max_gap_s); }

void MotionCalibrationOptions::read(const YamlReader& r, const YAML::Node& node,
                                    const std::string& field) {
  r.rejectUnknownKeys(
      node,
      {"min_pair_interval_s", "max_pair_interval_s", "sigma_translation_m", "sigma_rotation_deg",
       "huber", "min_rotation_for_axis_deg", "max_translation_sigma_m", "max_rotation_sigma_deg",
       "prior_translation_m", "prior_translation_sigma_m", "prior_rotation_xyzw",
       "prior_rotation_sigma_deg", "max_iterations", "translation_from_camera_orientation"},
      field);
  const Section s{r, node, field};
  s.number("min_pair_interval_s", min_pair_interval_s);
  s.number("max_pair_interval_s", max_pair_interval_s);
  s.number("sigma_translation_m", sigma_translation_m);
  s.number("sigma_rotation_deg", sigma_rotation_deg);
  s.number("huber", huber);
  s.number("min_rotation_for_axis_deg", min_rotation_for_axis_deg);
  s.number("max_translation_sigma_m", max_translation_sigma_m);
  s.number("max_rotation_sigma_deg", max_rotation_sigma_deg);
  s.optionalVector3("prior_translation_m", prior_translation_m);
  s.number("prior_translation_sigma_m", prior_translation_sigma_m);
  s.optionalQuaternion("prior_rotation_xyzw", prior_rotation);
  s.number("prior_rotation_sigma_deg", prior_rotation_sigma_deg);
  s.integer("max_iterations", max_iterations);
  if (node["translation_from_camera_orientation"]) {
    translation_from_camera_orientation = r.boolean(node["translation_from_camera_orientation"],
                                                    field + ".translation_from_camera_orientation");
  }
}

std::string MotionCalibrationOptions::check() const {
  for (const auto& [name, value] : std::initializer_list<std::pair<const char*, double>>{
           {"min_pair_interval_s", min_pair_interval_s},
           {"max_pair_interval_s", max_pair_interval_s},
           {"sigma_translation_m", sigma_translation_m},
           {"sigma_rotation_deg", sigma_rotation_deg},
           {"huber", huber},
           {"max_translation_sigma_m", max_translation_sigma_m},
           {"max_rotation_sigma_deg", max_rotation_sigma_deg},
           {"prior_translation_sigma_m", prior_translation_sigma_m},
           {"prior_rotation_sigma_deg", prior_rotation_sigma_deg}}) {
    if (std::string why = positive(name, value); !why.empty()) return why;
  }
  if (max_pair_interval_s < min_pair_interval_s) {
    return "'max_pair_interval_s': must be at least min_pair_interval_s";
  }
  if (min_rotation_for_axis_deg < 0) return "'min_rotation_for_axis_deg': must not be negative";
  if (max_iterations < 1) return "'max_iterations': must be at least 1";
  return "";
}

void LookDownOptions::read(const YamlReader& r, const YAML::Node& node, const std::string& field) {
  r.rejectUnknownKeys(
      node,
      {"min_detections", "suspect_min_detections", "suspect_rejected_fraction", "huber",
       "reject_chi2", "robot_position_sigma_m", "robot_rotation_sigma_deg",
       "default_translation_sigma_m", "default_rotation_sigma_deg", "consensus_radius_m"},
      field);
  const Section s{r, node, field};
  s.integer("min_detections", min_detections);
  s.integer("suspect_min_detections", suspect_min_detections);
  s.number("suspect_rejected_fraction", suspect_rejected_fraction);
  s.number("huber", huber);
  s.number("reject_chi2", reject_chi2);
  s.number("robot_position_sigma_m", robot_position_sigma_m);
  s.number("robot_rotation_sigma_deg", robot_rotation_sigma_deg);
  s.number("default_translation_sigma_m", default_translation_sigma_m);
  s.number("default_rotation_sigma_deg", default_rotation_sigma_deg);
  s.number("consensus_radius_m", consensus_radius_m);
}

std::string LookDownOptions::check() const {
  if (min_detections < 1) return "'min_detections': must be at least 1";
  if (suspect_min_detections < min_detections) {
    return "'suspect_min_detections': must be at least min_detections";
  }
  if (!(suspect_rejected_fraction >= 0 && suspect_rejected_fraction <= 1)) {
    return "'suspect_rejected_fraction': must be in [0, 1]";
  }
  for (const auto& [name, value] : std::initializer_list<std::pair<const char*, double>>{
           {"huber", huber},
           {"reject_chi2", reject_chi2},
           {"default_translation_sigma_m", default_translation_sigma_m},
           {"default_rotation_sigma_deg", default_rotation_sigma_deg},
           {"consensus_radius_m", consensus_radius_m}}) {
    if (std::string why = positive(name, value); !why.empty()) return why;
  }
  if (robot_position_sigma_m < 0) return "'robot_position_sigma_m': must not be negative";
  if (robot_rotation_sigma_deg < 0) return "'robot_rotation_sigma_deg': must not be negative";
  return "";
}

void LookUpOptions::read(const YamlReader& r, const YAML::Node& node, const std::string& field) {
  r.rejectUnknownKeys(node,
                      {"gate_px", "min_gate_px", "ambiguity_ratio", "cauchy_px", "rounds",
                       "max_blobs_per_camera", "association_frame_step", "min_blobs", "max_shift_m",
                       "blob_offset_in_camera_m", "max_gap_s"},
                      field);
  const Section s{r, node, field};
  s.number("gate_px", gate_px);
  s.number("min_gate_px", min_gate_px);
  s.number("ambiguity_ratio", ambiguity_ratio);
  s.number("cauchy_px", cauchy_px);
  s.integer("rounds", rounds);
  s.integer("max_blobs_per_camera", max_blobs_per_camera);
  s.integer("association_frame_step", association_frame_step);
  s.integer("min_blobs", min_blobs);
  s.number("max_shift_m", max_shift_m);
  s.vector3("blob_offset_in_camera_m", blob_offset_in_camera_m);
  s.number("max_gap_s", max_gap_s);
}

std::string LookUpOptions::check() const {
  for (const auto& [name, value] :
       std::initializer_list<std::pair<const char*, double>>{{"gate_px", gate_px},
                                                             {"cauchy_px", cauchy_px},
                                                             {"max_shift_m", max_shift_m},
                                                             {"max_gap_s", max_gap_s}}) {
    if (std::string why = positive(name, value); !why.empty()) return why;
  }
  if (ambiguity_ratio < 1) return "'ambiguity_ratio': must be at least 1";
  if (!(min_gate_px > 0) || min_gate_px > gate_px) {
    return "'min_gate_px': must be positive and at most gate_px";
  }
  // Each round is a full association and solve: a few are enough, thousands
  // are a typo that would run for days.
  if (rounds < 1 || rounds > 100) return "'rounds': must be 1-100, got " + std::to_string(rounds);
  if (min_blobs < 1) return "'min_blobs': must be at least 1";
  if (max_blobs_per_camera < 0) return "'max_blobs_per_camera': must not be negative";
  if (association_frame_step < 1) return "'association_frame_step': must be at least 1";
  return "";
}

void JointOptions::read(const YamlReader& r, const YAML::Node& node, const std::string& field) {
  r.rejectUnknownKeys(node,
                      {"node_interval_s",
                       "smooth_input_s",
                       "smooth_input_min_rms_m",
                       "drift_m_per_sqrt_m",
                       "drift_deg_per_sqrt_m",
                       "min_sigma_m",
                       "min_sigma_deg",
                       "drift_vertical_ratio",
                       "drift_tilt_ratio",
                       "estimate_drift_model",
                       "drift_model_updates",
                       "drift_round_max_blobs_per_camera",
                       "drift_round_max_iterations",
                       "scale_segment_m",
                       "scale_walk_sigma",
                       "metric_scale_sigma",
                       "fix_trajectory",
                       "fix_fisheye_from_marker",
                       "fisheye_from_marker_from_ground_truth",
                       "prior_translation_sigma_m",
                       "prior_rotation_sigma_deg",
                       "max_translation_sigma_m",
                       "max_rotation_sigma_deg",
                       "estimate_clock_offsets",
                       "clock_prior_sigma_s",
                       "max_clock_sigma_ms",
                       "use_corners",
                       "huber",
                       "reject_chi2_pose",
                       "reject_chi2_corners",
                       "estimate_variance_factor",
                       "pass_error_share",
                       "blob_pass_error_share",
                       "pass_gap_s",
                       "default_translation_sigma_m",
                       "default_rotation_sigma_deg",
                       "min_detections",
                       "use_blobs",
                       "blob_sigma_px",
                       "cauchy",
                       "gate_px",
                       "ambiguity_ratio",
                       "association_frame_step",
                       "max_blobs_per_camera",
                       "min_blobs",
                       "blob_offset_in_camera_m",
                       "rounds",
                       "max_iterations",
                       "early_round_max_iterations",
                       "function_tolerance",
                       "initial_trust_region_radius",
                       "linear_solver",
                       "fill_reducing_ordering",
                       "covariance",
                       "aligned_uncertainty_max_cameras",
                       "threads"},
                      field);
  const Section s{r, node, field};
  auto flag = [&](const char* key, bool& target) {
    if (node[key]) target = r.boolean(node[key], s.path(key));
  };
  s.number("node_interval_s", node_interval_s);
  s.number("smooth_input_s", smooth_input_s);
  s.number("smooth_input_min_rms_m", smooth_input_min_rms_m);
  s.number("drift_m_per_sqrt_m", drift_m_per_sqrt_m);
  s.number("drift_deg_per_sqrt_m", drift_deg_per_sqrt_m);
  s.number("drift_vertical_ratio", drift_vertical_ratio);
  s.number("drift_tilt_ratio", drift_tilt_ratio);
  flag("estimate_drift_model", estimate_drift_model);
  s.integer("drift_model_updates", drift_model_updates);
  s.integer("drift_round_max_blobs_per_camera", drift_round_max_blobs_per_camera);
  s.integer("drift_round_max_iterations", drift_round_max_iterations);
  s.number("min_sigma_m", min_sigma_m);
  s.number("min_sigma_deg", min_sigma_deg);
  s.number("scale_segment_m", scale_segment_m);
  s.number("scale_walk_sigma", scale_walk_sigma);
  s.number("metric_scale_sigma", metric_scale_sigma);
  flag("fix_trajectory", fix_trajectory);
  flag("fix_fisheye_from_marker", fix_fisheye_from_marker);
  flag("fisheye_from_marker_from_ground_truth", fisheye_from_marker_from_ground_truth);
  s.number("prior_translation_sigma_m", prior_translation_sigma_m);
  s.number("prior_rotation_sigma_deg", prior_rotation_sigma_deg);
  s.number("max_translation_sigma_m", max_translation_sigma_m);
  s.number("max_rotation_sigma_deg", max_rotation_sigma_deg);
  flag("estimate_clock_offsets", estimate_clock_offsets);
  s.number("clock_prior_sigma_s", clock_prior_sigma_s);
  s.number("max_clock_sigma_ms", max_clock_sigma_ms);
  flag("use_corners", use_corners);
  s.number("huber", huber);
  s.number("reject_chi2_pose", reject_chi2_pose);
  s.number("reject_chi2_corners", reject_chi2_corners);
  flag("estimate_variance_factor", estimate_variance_factor);
  s.number("pass_error_share", pass_error_share);
  s.number("blob_pass_error_share", blob_pass_error_share);
  s.number("pass_gap_s", pass_gap_s);
  s.number("default_translation_sigma_m", default_translation_sigma_m);
  s.number("default_rotation_sigma_deg", default_rotation_sigma_deg);
  s.integer("min_detections", min_detections);
  flag("use_blobs", use_blobs);
  s.number("blob_sigma_px", blob_sigma_px);
  s.number("cauchy", cauchy);
  s.number("gate_px", gate_px);
  s.number("ambiguity_ratio", ambiguity_ratio);
  s.integer("association_frame_step", association_frame_step);
  s.integer("max_blobs_per_camera", max_blobs_per_camera);
  s.integer("min_blobs", min_blobs);
  s.vector3("blob_offset_in_camera_m", blob_offset_in_camera_m);
  s.integer("rounds", rounds);
  s.integer("max_iterations", max_iterations);
  s.integer("early_round_max_iterations", early_round_max_iterations);
  s.number("function_tolerance", function_tolerance);
  s.number("initial_trust_region_radius", initial_trust_region_radius);
  if (node["linear_solver"]) linear_solver = r.text(node["linear_solver"], s.path("linear_solver"));
  if (node["fill_reducing_ordering"]) {
    fill_reducing_ordering =
        r.text(node["fill_reducing_ordering"], s.path("fill_reducing_ordering"));
  }
  flag("covariance", covariance);
  s.integer("aligned_uncertainty_max_cameras", aligned_uncertainty_max_cameras);
  s.integer("threads", threads);
}

std::string JointOptions::check() const {
  for (const auto& [name, value] : std::initializer_list<std::pair<const char*, double>>{
           {"scale_segment_m", scale_segment_m},
           {"drift_vertical_ratio", drift_vertical_ratio},
           {"drift_tilt_ratio", drift_tilt_ratio},
           {"scale_walk_sigma", scale_walk_sigma},
           {"metric_scale_sigma", metric_scale_sigma},
           {"prior_translation_sigma_m", prior_translation_sigma_m},
           {"prior_rotation_sigma_deg", prior_rotation_sigma_deg},
           {"max_translation_sigma_m", max_translation_sigma_m},
           {"max_rotation_sigma_deg", max_rotation_sigma_deg},
           {"clock_prior_sigma_s", clock_prior_sigma_s},
           {"max_clock_sigma_ms", max_clock_sigma_ms},
           {"huber", huber},
           {"reject_chi2_pose", reject_chi2_pose},
           {"reject_chi2_corners", reject_chi2_corners},
           {"default_translation_sigma_m", default_translation_sigma_m},
           {"default_rotation_sigma_deg", default_rotation_sigma_deg},
           {"blob_sigma_px", blob_sigma_px},
           {"cauchy", cauchy},
           {"gate_px", gate_px}}) {
    if (std::string why = positive(name, value); !why.empty()) return why;
  }
  for (const auto& [name, value] : std::initializer_list<std::pair<const char*, double>>{
           {"node_interval_s", node_interval_s},
           {"smooth_input_s", smooth_input_s},
           {"smooth_input_min_rms_m", smooth_input_min_rms_m},
           {"drift_m_per_sqrt_m", drift_m_per_sqrt_m},
           {"drift_deg_per_sqrt_m", drift_deg_per_sqrt_m}}) {
    if (!(value >= 0) || !std::isfinite(value)) {
      return std::string("'") + name + "': must not be negative, got " + formatDouble(value);
    }
  }
  if (!(min_sigma_m > 0) || !(min_sigma_deg > 0)) {
    return "'min_sigma_m', 'min_sigma_deg': must be positive (they keep the trajectory's "
           "relative-motion factors finite)";
  }
  for (const auto& [name, value] : std::initializer_list<std::pair<const char*, double>>{
           {"pass_error_share", pass_error_share},
           {"blob_pass_error_share", blob_pass_error_share}}) {
    if (!(value >= 0 && value <= 1)) {
      return std::string("'") + name + "': must be between 0 and 1, got " + formatDouble(value);
    }
  }
  if (!(pass_gap_s > 0) || !std::isfinite(pass_gap_s)) {
    return "'pass_gap_s': must be positive, got " + formatDouble(pass_gap_s);
  }
  if (ambiguity_ratio < 1) return "'ambiguity_ratio': must be at least 1";
  if (min_detections < 1) return "'min_detections': must be at least 1";
  if (min_blobs < 1) return "'min_blobs': must be at least 1";
  if (association_frame_step < 1) return "'association_frame_step': must be at least 1";
  if (max_blobs_per_camera < 0) return "'max_blobs_per_camera': must not be negative";
  // Each round is a full association and solve: a few are enough, thousands
  // are a typo that would run for days.
  if (rounds < 1 || rounds > 100) return "'rounds': must be 1-100, got " + std::to_string(rounds);
  if (drift_model_updates < 0 || drift_model_updates > 100)
    return "'drift_model_updates': must be 0-100, got " + std::to_string(drift_model_updates);
  if (drift_round_max_blobs_per_camera < 0) {
    return "'drift_round_max_blobs_per_camera': must not be negative (0 = max_blobs_per_camera)";
  }
  if (drift_round_max_iterations < 0) {
    return "'drift_round_max_iterations': must not be negative (0 = early_round_max_iterations)";
  }
  if (max_iterations < 1) return "'max_iterations': must be at least 1";
  if (early_round_max_iterations < 0) {
    return "'early_round_max_iterations': must not be negative (0 = max_iterations)";
  }
  if (aligned_uncertainty_max_cameras < 0) {
    return "'aligned_uncertainty_max_cameras': must not be negative (0 = never)";
  }
  if (threads < 1 || threads > 256) return "'threads': must be 1-256";
  if (!(initial_trust_region_radius > 0 && std::isfinite(initial_trust_region_radius))) {
    return "'initial_trust_region_radius': must be positive and finite, got " +
           formatDouble(initial_trust_region_radius);
  }
  if (!(function_tolerance > 0 && function_tolerance < 1)) {
    return "'function_tolerance': must be in (0, 1), got " + formatDouble(function_tolerance);
  }
  if (linear_solver != "sparse_normal_cholesky" && linear_solver != "sparse_schur" &&
      linear_solver != "iterative_schur") {
    return "'linear_solver': must be sparse_normal_cholesky, sparse_schur or iterative_schur, got "
           "'" +
           linear_solver + "'";
  }
  if (FillOrderingMethod method; !parseFillOrderingMethod(fill_reducing_ordering, &method)) {
    return "'fill_reducing_ordering': must be auto, amd or nested_dissection, got '" +
           fill_reducing_ordering + "'";
  }
  return "";
}

}  // namespace lookboth
