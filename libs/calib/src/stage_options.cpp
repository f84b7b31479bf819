// Options of the paper's stages: their keys, listed once in a fields()
// function that reads and writes them (lookboth/core/option_fields.h), and
// their checks.
#include <cmath>
#include <set>
#include <vector>

#include "lookboth/calib/builtin_stages.h"
#include "lookboth/core/option_fields.h"
#include "lookboth/core/text.h"
#include "lookboth/solver/fill_reducing_ordering.h"

namespace lookboth {
namespace {

// Eigen values as lists of numbers in a configuration section.
void vector3(OptionFields& f, const char* key, Eigen::Vector3d& target) {
  std::vector<double> v{target.x(), target.y(), target.z()};
  if (f.numbers(key, v, "[x, y, z]") && f.isReading()) target = Eigen::Vector3d(v[0], v[1], v[2]);
}

/// Null (~) clears it.
void optionalVector3(OptionFields& f, const char* key, std::optional<Eigen::Vector3d>& target) {
  const Eigen::Vector3d current = target.value_or(Eigen::Vector3d::Zero());
  std::vector<double> v{current.x(), current.y(), current.z()};
  bool present = target.has_value();
  if (!f.numbers(key, v, "[x, y, z]", &present) || !f.isReading()) return;
  if (present) {
    target = Eigen::Vector3d(v[0], v[1], v[2]);
  } else {
    target.reset();
  }
}

/// [qx, qy, qz, qw] of norm 1; null (~) clears it.
void optionalQuaternion(OptionFields& f, const char* key,
                        std::optional<Eigen::Quaterniond>& target) {
  const Eigen::Quaterniond current = target.value_or(Eigen::Quaterniond::Identity());
  std::vector<double> v{current.x(), current.y(), current.z(), current.w()};
  bool present = target.has_value();
  if (!f.numbers(key, v, "[qx, qy, qz, qw]", &present) || !f.isReading()) return;
  if (!present) {
    target.reset();
    return;
  }
  const Eigen::Quaterniond q(v[3], v[0], v[1], v[2]);
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    throw Error(f.reader().at(f.node(key), f.path(key)), "quaternion norm is not 1");
  }
  target = q.normalized();
}

}  // namespace

// The keys of each stage's options, in one list that reads and writes them
// (found by readOptions and writeOptions through argument-dependent lookup:
// in namespace lookboth, not in an unnamed one).
static void fields(AssociateOptions& o, OptionFields& s) {
  s.number("max_gap_s", o.max_gap_s);
  s.integers("clock_offsets_ns", o.clock_offsets_ns, "label: ns");
}

static void fields(MotionCalibrationOptions& o, OptionFields& s) {
  s.number("min_pair_interval_s", o.min_pair_interval_s);
  s.number("max_pair_interval_s", o.max_pair_interval_s);
  s.number("sigma_translation_m", o.sigma_translation_m);
  s.number("sigma_rotation_deg", o.sigma_rotation_deg);
  s.number("huber", o.huber);
  s.number("min_rotation_for_axis_deg", o.min_rotation_for_axis_deg);
  s.number("max_translation_sigma_m", o.max_translation_sigma_m);
  s.number("max_rotation_sigma_deg", o.max_rotation_sigma_deg);
  optionalVector3(s, "prior_translation_m", o.prior_translation_m);
  s.number("prior_translation_sigma_m", o.prior_translation_sigma_m);
  optionalQuaternion(s, "prior_rotation_xyzw", o.prior_rotation);
  s.number("prior_rotation_sigma_deg", o.prior_rotation_sigma_deg);
  s.integer("max_iterations", o.max_iterations);
  s.flag("translation_from_camera_orientation", o.translation_from_camera_orientation);
}

static void fields(LookDownOptions& o, OptionFields& s) {
  s.integer("min_detections", o.min_detections);
  s.integer("suspect_min_detections", o.suspect_min_detections);
  s.number("suspect_rejected_fraction", o.suspect_rejected_fraction);
  s.number("huber", o.huber);
  s.number("reject_chi2", o.reject_chi2);
  s.number("robot_position_sigma_m", o.robot_position_sigma_m);
  s.number("robot_rotation_sigma_deg", o.robot_rotation_sigma_deg);
  s.number("default_translation_sigma_m", o.default_translation_sigma_m);
  s.number("default_rotation_sigma_deg", o.default_rotation_sigma_deg);
  s.number("consensus_radius_m", o.consensus_radius_m);
}

static void fields(LookUpOptions& o, OptionFields& s) {
  s.number("gate_px", o.gate_px);
  s.number("min_gate_px", o.min_gate_px);
  s.number("ambiguity_ratio", o.ambiguity_ratio);
  s.number("cauchy_px", o.cauchy_px);
  s.integer("rounds", o.rounds);
  s.integer("max_blobs_per_camera", o.max_blobs_per_camera);
  s.integer("association_frame_step", o.association_frame_step);
  s.integer("min_blobs", o.min_blobs);
  s.number("max_shift_m", o.max_shift_m);
  vector3(s, "blob_offset_in_camera_m", o.blob_offset_in_camera_m);
  s.number("max_gap_s", o.max_gap_s);
}

static void fields(JointOptions& o, OptionFields& s) {
  s.number("node_interval_s", o.node_interval_s);
  s.number("smooth_input_s", o.smooth_input_s);
  s.number("smooth_input_min_rms_m", o.smooth_input_min_rms_m);
  s.number("drift_m_per_sqrt_m", o.drift_m_per_sqrt_m);
  s.number("drift_deg_per_sqrt_m", o.drift_deg_per_sqrt_m);
  s.number("drift_vertical_ratio", o.drift_vertical_ratio);
  s.number("drift_tilt_ratio", o.drift_tilt_ratio);
  s.flag("estimate_drift_model", o.estimate_drift_model);
  s.integer("drift_model_updates", o.drift_model_updates);
  s.integer("drift_round_max_blobs_per_camera", o.drift_round_max_blobs_per_camera);
  s.integer("drift_round_max_iterations", o.drift_round_max_iterations);
  s.number("min_sigma_m", o.min_sigma_m);
  s.number("min_sigma_deg", o.min_sigma_deg);
  s.number("between_samples_velocity_walk_mps_per_sqrt_s",
           o.between_samples_velocity_walk_mps_per_sqrt_s);
  s.number("between_samples_rate_walk_dps_per_sqrt_s", o.between_samples_rate_walk_dps_per_sqrt_s);
  s.number("scale_segment_m", o.scale_segment_m);
  s.number("scale_walk_sigma", o.scale_walk_sigma);
  s.number("metric_scale_sigma", o.metric_scale_sigma);
  s.flag("fix_trajectory", o.fix_trajectory);
  s.flag("fix_fisheye_from_marker", o.fix_fisheye_from_marker);
  s.flag("fisheye_from_marker_from_ground_truth", o.fisheye_from_marker_from_ground_truth);
  s.number("prior_translation_sigma_m", o.prior_translation_sigma_m);
  s.number("prior_rotation_sigma_deg", o.prior_rotation_sigma_deg);
  s.number("max_translation_sigma_m", o.max_translation_sigma_m);
  s.number("max_rotation_sigma_deg", o.max_rotation_sigma_deg);
  s.flag("estimate_clock_offsets", o.estimate_clock_offsets);
  s.number("clock_prior_sigma_s", o.clock_prior_sigma_s);
  s.number("unsynchronised_clock_prior_sigma_s", o.unsynchronised_clock_prior_sigma_s);
  s.number("max_clock_sigma_ms", o.max_clock_sigma_ms);
  s.flag("use_corners", o.use_corners);
  s.number("huber", o.huber);
  s.number("reject_chi2_pose", o.reject_chi2_pose);
  s.number("reject_chi2_corners", o.reject_chi2_corners);
  s.flag("estimate_variance_factor", o.estimate_variance_factor);
  s.number("pass_error_share", o.pass_error_share);
  s.number("blob_pass_error_share", o.blob_pass_error_share);
  s.number("pass_gap_s", o.pass_gap_s);
  s.flag("shared_errors_through_trajectory", o.shared_errors_through_trajectory);
  s.number("default_translation_sigma_m", o.default_translation_sigma_m);
  s.number("default_rotation_sigma_deg", o.default_rotation_sigma_deg);
  s.integer("min_detections", o.min_detections);
  s.flag("use_blobs", o.use_blobs);
  s.number("blob_sigma_px", o.blob_sigma_px);
  s.number("cauchy", o.cauchy);
  s.number("gate_px", o.gate_px);
  s.number("ambiguity_ratio", o.ambiguity_ratio);
  s.integer("association_frame_step", o.association_frame_step);
  s.integer("max_blobs_per_camera", o.max_blobs_per_camera);
  s.integer("min_blobs", o.min_blobs);
  vector3(s, "blob_offset_in_camera_m", o.blob_offset_in_camera_m);
  s.integer("rounds", o.rounds);
  s.integer("max_iterations", o.max_iterations);
  s.integer("early_round_max_iterations", o.early_round_max_iterations);
  s.number("function_tolerance", o.function_tolerance);
  s.number("initial_trust_region_radius", o.initial_trust_region_radius);
  s.text("linear_solver", o.linear_solver);
  s.text("fill_reducing_ordering", o.fill_reducing_ordering);
  s.flag("covariance", o.covariance);
  s.integer("aligned_uncertainty_max_cameras", o.aligned_uncertainty_max_cameras);
  s.integer("threads", o.threads);
}

namespace {

std::string positive(const char* name, double value) {
  if (!(value > 0) || !std::isfinite(value)) {
    return std::string("'") + name + "': must be positive, got " + formatDouble(value);
  }
  return "";
}

}  // namespace

void AssociateOptions::read(const YamlReader& r, const YAML::Node& node, const std::string& field) {
  readOptions(*this, r, node, field);
}

void AssociateOptions::write(YAML::Node& node) const { writeOptions(*this, node); }

std::string AssociateOptions::check() const { return positive("max_gap_s", max_gap_s); }

void MotionCalibrationOptions::read(const YamlReader& r, const YAML::Node& node,
                                    const std::string& field) {
  readOptions(*this, r, node, field);
}

void MotionCalibrationOptions::write(YAML::Node& node) const { writeOptions(*this, node); }

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
  readOptions(*this, r, node, field);
}

void LookDownOptions::write(YAML::Node& node) const { writeOptions(*this, node); }

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
  readOptions(*this, r, node, field);
}

void LookUpOptions::write(YAML::Node& node) const { writeOptions(*this, node); }

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
  readOptions(*this, r, node, field);
}

void JointOptions::write(YAML::Node& node) const { writeOptions(*this, node); }

std::string JointOptions::check() const {
  for (const auto& [name, value] : std::initializer_list<std::pair<const char*, double>>{
           {"scale_segment_m", scale_segment_m},
           {"drift_vertical_ratio", drift_vertical_ratio},
           {"drift_tilt_ratio", drift_tilt_ratio},
           {"between_samples_velocity_walk_mps_per_sqrt_s",
            between_samples_velocity_walk_mps_per_sqrt_s},
           {"between_samples_rate_walk_dps_per_sqrt_s", between_samples_rate_walk_dps_per_sqrt_s},
           {"scale_walk_sigma", scale_walk_sigma},
           {"metric_scale_sigma", metric_scale_sigma},
           {"prior_translation_sigma_m", prior_translation_sigma_m},
           {"prior_rotation_sigma_deg", prior_rotation_sigma_deg},
           {"max_translation_sigma_m", max_translation_sigma_m},
           {"max_rotation_sigma_deg", max_rotation_sigma_deg},
           {"clock_prior_sigma_s", clock_prior_sigma_s},
           {"unsynchronised_clock_prior_sigma_s", unsynchronised_clock_prior_sigma_s},
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
