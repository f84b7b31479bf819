// Stage `joint`: the setup steps (joint_adjustment.h).
#include <algorithm>
#include <iostream>

#include "joint_adjustment.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth {
namespace joint_detail {
namespace {

using calib_detail::sqrtInformation;

// A detection's square-root information: its own, or the configured sigmas
// (translation `dt` [m], rotation `dr` [rad]) when the detector gave none.
Matrix6d detectionSqrtInfo(const MarkerObservation& m, double dt, double dr) {
  if (m.information.isZero(0)) {
    Matrix6d info = Matrix6d::Zero();
    info.topLeftCorner<3, 3>().diagonal().setConstant(1.0 / (dt * dt));
    info.bottomRightCorner<3, 3>().diagonal().setConstant(1.0 / (dr * dr));
    return sqrtInformation(info);
  }
  return sqrtInformation(m.information);
}

}  // namespace

// What the earlier stages must have produced.
void JointAdjustment::checkInputs() const {
  if (!problem_.associated) {
    throw Error("joint needs associated detections: put 'associate' before it");
  }
  if (!problem_.fisheye_from_marker) {
    throw Error(
        "joint needs fisheye_from_marker and the scale: put 'motion_calibration' before it");
  }
  bool any_pose = false;
  for (const CameraRegistration& c : result_.cameras) {
    if (c.stage_poses.count("look_down")) any_pose = true;
  }
  if (!any_pose && !result_.cameras.empty()) {
    throw Error("joint needs initial camera poses: put 'look_down' before it");
  }
}

// Visual mode: the input trajectory, its positions smoothed when they
// scatter about a smooth motion by more than smooth_input_min_rms_m (a
// visual odometry's frame-to-frame jitter). A smooth input is used as given,
// so that nothing biases an exact one, and so is a metric one (wheel
// odometry integrates; a fast robot's true jerk would pass for jitter).
void JointAdjustment::prepareReferenceTrajectory() {
  double input_scatter_m = 0;  // [m]
  std::vector<StampedPose> smoothed;
  if (visual_ && options_.smooth_input_s > 0) {
    smoothed = smoothPositions(input_.trajectory.samples(), options_.smooth_input_s,
                               kSmoothingGapNs, &input_scatter_m);
    input_scatter_m *= scale0_;  // the input's units to metres
  }
  const bool smooth_input = !smoothed.empty() && input_scatter_m > options_.smooth_input_min_rms_m;
  reference_.emplace(smooth_input ? Trajectory(std::move(smoothed)) : input_.trajectory);
  if (smooth_input) {
    result_.observability.message +=
        (result_.observability.message.empty() ? "" : " ") +
        std::string("joint: the input trajectory's positions scatter ") +
        formatFixed(input_scatter_m * 1e3, 2) + " mm RMS about local quadratic fits over +-" +
        formatFixed(options_.smooth_input_s, 2) + " s; they were smoothed (smooth_input_s).";
  }
  if (verbose_) {
    std::cerr << "joint: input positions scatter " << input_scatter_m * 1e3
              << " mm RMS about local quadratic fits over +-" << options_.smooth_input_s << " s"
              << (smooth_input ? ": smoothed" : ": used as given") << "\n";
  }
  samples_ = &reference_->samples();
  if (samples_->size() < 2) throw Error("joint: the trajectory has fewer than 2 samples");
  max_gap_ns_ = effectiveMaxGap(*reference_, kMaxGapNs);
}

// The start of fisheye_from_marker, and the priors on the components
// motion_calibration found undetermined.
void JointAdjustment::initFisheyeFromMarker() {
  X0_ = *problem_.fisheye_from_marker;
  if (options_.fisheye_from_marker_from_ground_truth) {
    if (!input_.manifest.ground_truth.fisheye_from_marker) {
      throw Error(
          "joint: fisheye_from_marker_from_ground_truth is set but the dataset has no ground-truth "
          "fisheye_from_marker");
    }
    X0_ = *input_.manifest.ground_truth.fisheye_from_marker;
  }
  poseToParams(X0_, x_params_);
  if (!options_.fix_fisheye_from_marker) {
    for (int c = 0; c < 6; ++c) prior_on_[c] = !result_.fisheye_from_marker_determined[c];
  }
}

// Nodes at input samples at least node_interval_s apart and, between two
// such samples more than twice that apart (a keyframe trajectory), every
// node_interval_s, started on the input's interpolation: there the
// detections bend the path the input does not sample, held smooth. Not
// across a gap.
void JointAdjustment::buildNodes() {
  const std::vector<StampedPose>& samples = *samples_;
  const TimeNs interval = static_cast<TimeNs>(options_.node_interval_s * 1e9);
  std::vector<std::size_t> chosen{0};
  for (std::size_t i = 1; i + 1 < samples.size(); ++i) {
    if (samples[i].t - samples[chosen.back()].t >= interval) chosen.push_back(i);
  }
  chosen.push_back(samples.size() - 1);
  for (std::size_t c = 0; c < chosen.size(); ++c) {
    const StampedPose& sample = samples[chosen[c]];
    bool gap = false;  // an interval of the input between the two is a gap
    if (c > 0) {
      for (std::size_t i = chosen[c - 1]; i < chosen[c]; ++i) {
        gap |= samples[i + 1].t - samples[i].t > max_gap_ns_;
      }
    }
    if (c > 0 && interval > 0 && !gap) {
      const TimeNs t0 = samples[chosen[c - 1]].t, span = sample.t - t0;
      const TimeNs added = span > 2 * interval ? span / interval - 1 : 0;
      for (TimeNs j = 1; j <= added; ++j) {
        const TimeNs t = t0 + span * j / (added + 1);
        pushNode(t, reference_->interpolate(t, 0).world_from_body, true, false);
      }
    }
    pushNode(sample.t, sample.world_from_body, false, gap);
  }
  buildEdges();
}

void JointAdjustment::pushNode(TimeNs t, const Rigid3d& input_pose, bool between_samples,
                               bool gap_before) {
  node_t_.push_back(t);
  node_input_.push_back(input_pose);
  node_ref_.push_back(problem_.metricWorldFromFisheye(input_pose));
  node_between_samples_.push_back(between_samples);
  node_gap_before_.push_back(gap_before);
  nodes_.emplace_back();
  poseToParams(node_ref_.back(), nodes_.back().data());
}

// The input's motion between consecutive sampled nodes (the drift model),
// the smooth motion over three consecutive nodes with an added one among
// them and no gap between them; scale segments by metric distance along the
// trajectory.
void JointAdjustment::buildEdges() {
  const std::size_t n_nodes = nodes_.size();
  std::vector<std::size_t> segment_of_node(n_nodes, 0);
  double travelled = 0;
  for (std::size_t k = 0; k + 1 < n_nodes; ++k) {
    segment_of_node[k] = static_cast<std::size_t>(travelled / options_.scale_segment_m);
    travelled += (node_ref_[k + 1].translation - node_ref_[k].translation).norm();
  }
  auto edge = [&](std::size_t from, std::size_t to) {
    TrajectoryEdge e;
    e.from = from;
    e.to = to;
    e.gap = node_gap_before_[to];
    e.segment = segment_of_node[from];
    e.length_m = (node_ref_[to].translation - node_ref_[from].translation).norm();
    edges_.push_back(e);
  };
  std::size_t last_sampled = 0;
  for (std::size_t k = 1; k < n_nodes; ++k) {
    if (k + 1 < n_nodes && !node_gap_before_[k] && !node_gap_before_[k + 1] &&
        (node_between_samples_[k - 1] || node_between_samples_[k] ||
         node_between_samples_[k + 1])) {
      smooth_middles_.push_back(k);
    }
    if (node_between_samples_[k]) continue;
    edge(last_sampled, k);
    last_sampled = k;
  }
  n_segments_ = 1;
  for (const TrajectoryEdge& e : edges_) n_segments_ = std::max(n_segments_, e.segment + 1);
  scales_.assign(n_segments_, visual_ ? scale0_ : 1.0);
}

std::optional<Rigid3d> JointAdjustment::referenceAt(TimeNs t) const {
  const InterpolationResult r = reference_->interpolate(t, max_gap_ns_);
  if (!r.ok()) return std::nullopt;
  return problem_.metricWorldFromFisheye(r.world_from_body);
}

std::optional<Bracket> JointAdjustment::bracketAt(TimeNs t, bool with_velocity) const {
  const std::size_t n_nodes = nodes_.size();
  if (t < node_t_.front() || t > node_t_.back()) return std::nullopt;
  std::size_t k = static_cast<std::size_t>(std::upper_bound(node_t_.begin(), node_t_.end(), t) -
                                           node_t_.begin());
  k = k == 0 ? 0 : k - 1;
  if (k + 1 >= n_nodes) k = n_nodes - 2;
  const auto reference = referenceAt(t);
  if (!reference) return std::nullopt;
  Bracket b;
  b.k = k;
  b.duration_s = nsToSeconds(node_t_[k + 1] - node_t_[k]);
  b.tau_ref_s = nsToSeconds(t - node_t_[k]);
  b.ref_inverse_k = node_ref_[k].inverse();
  b.ref_inverse_k1 = node_ref_[k + 1].inverse();
  b.reference = *reference;
  if (with_velocity) {
    const TimeNs h = 5'000'000;  // 5 ms
    const TimeNs lo = std::max(t - h, node_t_.front()), hi = std::min(t + h, node_t_.back());
    const auto a = referenceAt(lo), c = referenceAt(hi);
    if (a && c && hi > lo) {
      const double dt = nsToSeconds(hi - lo);
      b.velocity_world = (c->translation - a->translation) / dt;
      b.omega_body =
          so3Log(Eigen::Quaterniond(reference->rotation.conjugate() * c->rotation)) / dt -
          so3Log(Eigen::Quaterniond(reference->rotation.conjugate() * a->rotation)) / dt;
    }
  }
  return b;
}

Rigid3d JointAdjustment::evalPose(const Bracket& b, double tau_s) const {
  return poseAt<double>(b, nodes_[b.k].data(), nodes_[b.k + 1].data(), tau_s);
}

// Every camera of the registration that look_down registered, and those it
// did not that a clock search can start (restartCamera).
void JointAdjustment::initCameras() {
  std::map<std::string, const Camera*> env_models;
  for (const CameraSensor& s : input_.manifest.cameras) {
    if (s.role == SensorRole::kEnvCamera && s.camera) env_models[s.label] = &*s.camera;
  }
  std::map<std::string, TimeNs> configured_offsets;
  for (const Association& a : problem_.associations) {
    configured_offsets[problem_.marker(a).camera] = problem_.marker(a).t - a.t_robot;
  }
  // The fisheye model when the blobs can be used (the clock searches).
  if (options_.use_blobs && !input_.blobs.empty()) {
    const CameraSensor* f = input_.manifest.fisheye();
    if (f && f->camera) blob_fisheye_ = &*f->camera;
  }
  for (CameraRegistration& c : result_.cameras) {
    Rigid3d start = c.world_from_camera;
    if (c.status != CameraStatus::kRegistered) {
      const auto restart = restartCamera(c);
      if (!restart) continue;
      start = restart->first;
      restarted_[c.label] = restart->second;
    }
    JointCamera jc;
    jc.registration = &c;
    const auto model = env_models.find(c.label);
    jc.model = model == env_models.end() ? nullptr : model->second;
    poseToParams(start, jc.pose);
    jc.start = start;
    const auto offset = configured_offsets.find(c.label);
    jc.offset0_s = offset == configured_offsets.end() ? 0.0 : nsToSeconds(offset->second);
    jc.offset_s = jc.offset0_s;
    if (const auto r = restarted_.find(c.label); r != restarted_.end()) jc.offset_s += r->second;
    jc.judgeClock();
    if (const auto prior = problem_.camera_priors.find(c.label);
        prior != problem_.camera_priors.end()) {
      jc.prior = prior->second.world_from_camera;
      jc.prior_sqrt_info = sqrtInformation(prior->second.covariance.inverse());
      held_by_priors_ = true;
    }
    cameras_.push_back(jc);
  }
  const double half_side = 0.5 * input_.manifest.marker.size_m;
  corners_in_marker_ = {
      Eigen::Vector3d(-half_side, half_side, 0), Eigen::Vector3d(half_side, half_side, 0),
      Eigen::Vector3d(half_side, -half_side, 0), Eigen::Vector3d(-half_side, -half_side, 0)};
  restarted_now_.assign(cameras_.size(), false);
}

// The adjustment's cameras' detections; round 0 starts from look_down's inliers.
void JointAdjustment::collectDetections() {
  std::map<std::string, std::size_t> index;
  for (std::size_t c = 0; c < cameras_.size(); ++c) index[cameras_[c].registration->label] = c;
  for (const auto& [label, indices] : problem_.associations_by_camera) {
    const auto found = index.find(label);
    if (found == index.end()) continue;
    const auto inliers = problem_.inliers_by_camera.find(label);
    for (std::size_t a : indices) {
      const MarkerObservation& m = problem_.marker(problem_.associations[a]);
      Detection d;
      d.association = a;
      d.camera = found->second;
      d.t_camera = m.t;
      d.corners = options_.use_corners && m.corners_px.size() == 4 && m.corner_sigma_px > 0 &&
                  cameras_[found->second].model != nullptr &&
                  cameras_[found->second].model->params().size() <= kMaxParams;
      d.sqrt_info = detectionSqrtInfo(m, options_.default_translation_sigma_m,
                                      options_.default_rotation_sigma_deg * kDeg);
      d.inlier =
          restarted_.count(label) > 0 || inliers == problem_.inliers_by_camera.end() ||
          std::find(inliers->second.begin(), inliers->second.end(), a) != inliers->second.end();
      cameras_[found->second].detections.push_back(detections_.size());
      detections_.push_back(d);
    }
  }
  det_bracket_.assign(detections_.size(), std::nullopt);
}

// The fisheye's frames with blobs, when its calibration can be used.
void JointAdjustment::collectBlobFrames() {
  const CameraSensor* fisheye_sensor = input_.manifest.fisheye();
  fisheye_ = fisheye_sensor && fisheye_sensor->camera ? &*fisheye_sensor->camera : nullptr;
  use_blobs_ = options_.use_blobs && fisheye_ && !input_.blobs.empty() &&
               fisheye_->params().size() <= kMaxParams;
  if (options_.use_blobs && !use_blobs_ && !input_.blobs.empty()) {
    result_.warnings.push_back("joint: the fisheye has no usable calibration; blobs not used");
  }
  if (use_blobs_) {
    for (const BlobObservation& b : input_.blobs) {
      if (b.blobs.empty()) continue;
      if (const auto bracket = bracketAt(b.t, false)) frames_.push_back({&b, *bracket});
    }
  }
  matches_.assign(cameras_.size(), {});
}

// A joint run before on this problem corrected the trajectory, estimated the
// drift model and the clock offsets: start from them, so that a second run
// (with camera priors, `register --update`) converges in a round or two. The
// drift model, estimated from the same data, is kept (priors on a few cameras
// hardly change it, and each update costs a covariance and a round). The
// input trajectory stays the reference the relative motions measure.
void JointAdjustment::startFromEarlierRun() {
  if (!problem_.metric_trajectory || options_.fix_trajectory) return;
  const std::vector<StampedPose>& corrected = *problem_.metric_trajectory;
  auto byTime = [](const StampedPose& p, TimeNs t) { return p.t < t; };
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    const auto found = std::lower_bound(corrected.begin(), corrected.end(), node_t_[k], byTime);
    if (found != corrected.end() && found->t == node_t_[k]) {
      poseToParams(found->world_from_body, nodes_[k].data());
    }
  }
  if (options_.estimate_drift_model && result_.observability.drift_model) {
    const DriftModelEstimate& e = *result_.observability.drift_model;
    drift_.factor[0] = e.horizontal;
    drift_.factor[1] = e.vertical;
    drift_.factor[2] = e.tilt;
    drift_.factor[3] = e.yaw;
    drift_.factor[4] = e.between_samples_velocity_walk.value_or(1.0);
    drift_.factor[5] = e.between_samples_rate_walk.value_or(1.0);
    drift_.updates = e.updates;
    drift_model_given_ = true;
  }
  for (JointCamera& c : cameras_) {
    const auto& offset = c.registration->clock_offset;
    if (offset && offset->estimated && !restarted_.count(c.registration->label)) {
      c.offset_s = nsToSeconds(offset->offset_ns);
      c.judgeClock();
    }
  }
}

void JointAdjustment::configureSolver() {
  if (options_.linear_solver == "sparse_schur") {
    solver_.linear_solver_type = ceres::SPARSE_SCHUR;
  } else if (options_.linear_solver == "iterative_schur") {
    solver_.linear_solver_type = ceres::ITERATIVE_SCHUR;
    solver_.preconditioner_type = ceres::SCHUR_JACOBI;
  } else {
    solver_.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  }
  parseFillOrderingMethod(options_.fill_reducing_ordering,
                          &fill_method_);  // check()ed
  solver_.max_num_iterations = options_.max_iterations;
  solver_.num_threads = options_.threads;
  solver_.function_tolerance = options_.function_tolerance;
  solver_.gradient_tolerance = 1e-12;
  solver_.parameter_tolerance = 1e-9;
  solver_.initial_trust_region_radius = options_.initial_trust_region_radius;
  solver_.minimizer_progress_to_stdout = verbose_every_round_;  // =2: every iteration
  max_rounds_ =
      options_.rounds + (options_.estimate_drift_model ? options_.drift_model_updates : 0);
}

}  // namespace joint_detail
}  // namespace lookboth
