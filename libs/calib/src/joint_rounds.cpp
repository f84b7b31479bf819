// Stage `joint`: the rounds (joint_adjustment.h). Each round brackets the
// detections at the current clock offsets, rejects outliers at the current
// estimate, associates the blobs, builds the Ceres problem and solves it.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <sstream>

#include "blob_association.h"
#include "joint_adjustment.h"
#include "joint_costs.h"
#include "lookboth/core/error.h"
#include "lookboth/core/threads.h"

namespace lookboth::joint_detail {

void JointAdjustment::solveRounds() {
  lap();
  for (int round = 0; round < max_rounds_; ++round) {
    if (!roundNeeded(round)) break;
    inliers_judged_converged_ = previous_converged_;
    const bool drift_update_follows = driftUpdateFollows(round);
    progress_.checkStop();
    progress_.report("joint", round, max_rounds_, "round " + std::to_string(round + 1));
    if (round == 1 && blob_fisheye_ != nullptr && options_.estimate_clock_offsets) {
      researchRestartedClocks();
    }
    bracketDetections();
    if (round > 0 && !previous_short_) rejectOutliers(round);
    associateBlobs();
    if (!inputsChanged(round)) break;
    buildProblem(drift_update_follows);
    chooseOrdering();
    solveRound(round, drift_update_follows);
    drift_.changed = false;
    if (drift_update_follows) {
      drift_.changed = updateDriftModel();
      if (!drift_.failed) ++drift_.updates;
      drift_.still_changing = drift_.changed;
    }
  }
}

// Rounds past `rounds` run only for a drift model that changed (or after a
// round that did not converge, or whose inliers were judged on an estimate
// that had not).
bool JointAdjustment::roundNeeded(int round) const {
  return round < options_.rounds || drift_.changed || !previous_converged_ ||
         !inliers_judged_converged_;
}

// A round whose solution serves only the next drift model update (another
// follows: the model is still changing) moves the estimate towards the
// weights of that update; the update re-weights it, and the round after the
// last update converges: such a round uses fewer blobs
// (drift_round_max_blobs_per_camera) and, after the first update, stops
// after drift_round_max_iterations steps (previous_short_).
bool JointAdjustment::driftUpdateFollows(int round) const {
  return options_.estimate_drift_model && !options_.fix_trajectory && !drift_.failed &&
         !drift_model_given_ && drift_.updates < options_.drift_model_updates &&
         (drift_.updates == 0 || drift_.still_changing) && round + 1 < max_rounds_;
}

// Detection brackets for the current offsets.
void JointAdjustment::bracketDetections() {
  for (std::size_t i = 0; i < detections_.size(); ++i) {
    const Detection& d = detections_[i];
    const TimeNs t_robot =
        d.t_camera - static_cast<TimeNs>(std::llround(cameras_[d.camera].offset_s * 1e9));
    det_bracket_[i] = bracketAt(t_robot, true);
    detections_[i].in_range = det_bracket_[i].has_value();
  }
}

// Outliers at the current estimate (every detection is reconsidered), after
// the variance factors are re-estimated from the medians.
void JointAdjustment::rejectOutliers(int round) {
  std::vector<double> chi2(detections_.size(), 0.0);
  std::vector<double> by_kind[2];
  for (std::size_t i = 0; i < detections_.size(); ++i) {
    if (!detections_[i].in_range) continue;
    const int kind = detections_[i].corners ? 1 : 0;
    chi2[i] = markerChi2(i) * variance_factor_[kind];  // as with factor 1
    if (!restarted_now_[detections_[i].camera]) by_kind[kind].push_back(chi2[i]);
  }
  // Medians of the chi-square distribution with 6 and 8 degrees of freedom.
  const double expected_median[2] = {5.3481, 7.3441};
  for (int kind = 0; kind < 2; ++kind) {
    std::vector<double>& v = by_kind[kind];
    if (v.size() < 10 || !options_.estimate_variance_factor) continue;
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    variance_factor_[kind] = std::max(1.0, v[v.size() / 2] / expected_median[kind]);
  }
  for (std::size_t i = 0; i < detections_.size(); ++i) {
    if (!detections_[i].in_range) continue;
    const int kind = detections_[i].corners ? 1 : 0;
    const double bound = kind ? options_.reject_chi2_corners : options_.reject_chi2_pose;
    detections_[i].inlier =
        restarted_now_[detections_[i].camera] || chi2[i] / variance_factor_[kind] <= bound;
  }
  std::fill(restarted_now_.begin(), restarted_now_.end(), false);
  if (verbose_) {
    std::cerr << "joint round " << round + 1 << ": variance factors pose " << variance_factor_[0]
              << ", corners " << variance_factor_[1] << "\n";
  }
}

// look_up's gated, unambiguous nearest-neighbour association of the blobs
// with the cameras' centres, at the current estimate.
void JointAdjustment::associateBlobs() {
  for (auto& m : matches_) m.clear();
  if (frames_.empty()) return;
  const double max_angle = std::min(fisheye_->maxIncidenceAngle(), 85.0 * kDeg);
  std::vector<std::pair<double, std::size_t>> by_x;
  std::vector<Eigen::Vector3d> centre(cameras_.size());
  double max_height = 0;
  const Eigen::Vector3d o0 =
      evalPose(frames_.front().bracket, frames_.front().bracket.tau_ref_s).translation;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const Rigid3d pose = paramsToPose(cameras_[c].pose);
    centre[c] = pose * options_.blob_offset_in_camera_m;
    by_x.emplace_back(centre[c].x(), c);
    max_height = std::max(max_height, std::abs(centre[c].z() - o0.z()));
  }
  std::sort(by_x.begin(), by_x.end());
  const double range = std::max(5.0, (max_height + 1.0) * std::tan(max_angle) + 2.0);
  std::vector<std::pair<std::size_t, Eigen::Vector2d>> projected;
  calib_detail::BlobsByColumn by_column;
  for (std::size_t fi = 0; fi < frames_.size();
       fi += static_cast<std::size_t>(options_.association_frame_step)) {
    const BlobFrame& f = frames_[fi];
    const Rigid3d world_from_fisheye = evalPose(f.bracket, f.bracket.tau_ref_s);
    const Rigid3d fisheye_from_world = world_from_fisheye.inverse();
    const Eigen::Vector3d o = world_from_fisheye.translation;
    const auto lo =
        std::lower_bound(by_x.begin(), by_x.end(), std::make_pair(o.x() - range, std::size_t(0)));
    projected.clear();
    for (auto it = lo; it != by_x.end() && it->first <= o.x() + range; ++it) {
      const std::size_t c = it->second;
      if (std::abs(centre[c].y() - o.y()) > range) continue;
      const Eigen::Vector3d p = fisheye_from_world * centre[c];
      if (p.z() <= 0) continue;
      const auto pixel = fisheye_->project(p);
      if (!pixel || !fisheye_->isInImage(*pixel, -options_.gate_px)) continue;
      projected.emplace_back(c, *pixel);
    }
    if (projected.empty()) continue;
    by_column.assign(f.blobs->blobs);
    for (const auto& [c, pixel] : projected) {
      if (const auto best = calib_detail::associatedBlob(by_column, c, pixel, options_.gate_px,
                                                         options_.ambiguity_ratio, projected)) {
        matches_[c].push_back({fi, *best});
      }
    }
  }
}

// Another round only when its inputs changed: inliers, blob associations
// (by more than 0.5 %), or a clock offset by more than 5 ms. Within that a
// detection's pose is the first-order expansion around the offset it was
// bracketed at, from the velocity over the same +-5 ms: its error is
// a dt^2 / 2, 0.025 mm at 2 m/s^2, so re-bracketing would change nothing.
bool JointAdjustment::inputsChanged(int round) {
  std::vector<char> inlier(detections_.size());
  for (std::size_t i = 0; i < detections_.size(); ++i) {
    inlier[i] = detections_[i].in_range && detections_[i].inlier;
  }
  std::vector<double> offsets;
  for (const JointCamera& c : cameras_) offsets.push_back(c.offset_s);
  std::size_t blobs_total = 0;
  for (const auto& m : matches_) blobs_total += m.size();
  if (round > 0 && inlier == previous_inlier_ &&
      std::abs(static_cast<double>(blobs_total) - static_cast<double>(previous_blobs_)) <=
          0.005 * static_cast<double>(previous_blobs_)) {
    double moved = 0;
    for (std::size_t c = 0; c < cameras_.size(); ++c) {
      moved = std::max(moved, std::abs(offsets[c] - previous_offset_[c]));
    }
    if (moved < kRebracketS && previous_converged_ && !drift_.changed) return false;
  }
  previous_inlier_ = inlier;
  previous_offset_ = offsets;
  previous_blobs_ = blobs_total;
  return true;
}

ceres::CostFunction* JointAdjustment::markerCost(std::size_t i) const {
  const Detection& d = detections_[i];
  const double factor = variance_factor_[d.corners ? 1 : 0];
  const Bracket& b = *det_bracket_[i];
  const MarkerObservation& m = problem_.marker(problem_.associations[d.association]);
  const double tau_camera = nsToSeconds(d.t_camera - node_t_[b.k]);
  if (d.corners) {
    MarkerCornersCost cost;
    cost.bracket = b;
    cost.tau_camera_s = tau_camera;
    cost.camera_model = cameras_[d.camera].model;
    cost.corners_in_marker = corners_in_marker_;
    for (int c = 0; c < 4; ++c) cost.observed[c] = m.corners_px[c];
    cost.sigma_px = m.corner_sigma_px * std::sqrt(factor);
    return new AnalyticMarkerCornersCost(cost);
  }
  MarkerPoseCost cost;
  cost.bracket = b;
  cost.tau_camera_s = tau_camera;
  cost.measured = m.camera_from_marker;
  cost.sqrt_info = d.sqrt_info / std::sqrt(factor);
  return new AnalyticMarkerPoseCost(cost);
}

double JointAdjustment::markerChi2(std::size_t i) const {
  std::unique_ptr<ceres::CostFunction> cost(markerCost(i));
  const Detection& d = detections_[i];
  const Bracket& b = *det_bracket_[i];
  const double* blocks[5] = {nodes_[b.k].data(), nodes_[b.k + 1].data(), x_params_,
                             cameras_[d.camera].pose, &cameras_[d.camera].offset_s};
  double r[8];
  if (!cost->Evaluate(blocks, r, nullptr)) return 1e300;
  double sum = 0;
  for (int k = 0; k < cost->num_residuals(); ++k) sum += r[k] * r[k];
  return sum;
}

void JointAdjustment::buildProblem(bool drift_update_follows) {
  ceres_problem_.reset();
  huber_ = std::make_unique<ceres::HuberLoss>(options_.huber);
  cauchy_ = std::make_unique<ceres::CauchyLoss>(options_.cauchy);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  frame_poses_ = std::make_shared<FramePoseCache>();
  problem_options.evaluation_callback = frame_poses_.get();
  ceres_problem_ = std::make_unique<ceres::Problem>(problem_options);
  for (auto& blocks : group_blocks_) blocks.clear();
  marker_blocks_.clear();
  blob_blocks_.clear();
  node_used_.assign(nodes_.size(), false);
  if (!options_.fix_trajectory) addTrajectory();
  addFisheyeFromMarker();
  addCamerasAndDetections();
  addBlobs(drift_update_follows);
  // Gauge and fixed parts.
  ceres::Problem& Q = *ceres_problem_;
  addNode(0);
  if (!held_by_priors_) Q.SetParameterBlockConstant(nodes_[0].data());
  if (options_.fix_trajectory) {
    for (std::size_t k = 0; k < nodes_.size(); ++k) {
      if (node_used_[k]) Q.SetParameterBlockConstant(nodes_[k].data());
    }
  }
  if (options_.fix_fisheye_from_marker) Q.SetParameterBlockConstant(x_params_);
}

void JointAdjustment::addNode(std::size_t k) {
  if (node_used_[k]) return;
  node_used_[k] = true;
  ceres_problem_->AddParameterBlock(nodes_[k].data(), 7, newPoseManifold());
}

// Trajectory: relative motions weighted by the drift model (between the
// input's samples), the smooth motion where nodes were added between them,
// and scales.
void JointAdjustment::addTrajectory() {
  ceres::Problem& Q = *ceres_problem_;
  const double* factor = drift_.factor;
  drift_residuals_.clear();
  for (const TrajectoryEdge& e : edges_) {
    addNode(e.from);
    addNode(e.to);
    double sigma_t =
        std::hypot(options_.min_sigma_m, options_.drift_m_per_sqrt_m * std::sqrt(e.length_m)) *
        factor[0];
    double sigma_r = std::hypot(options_.min_sigma_deg * kDeg,
                                options_.drift_deg_per_sqrt_m * kDeg * std::sqrt(e.length_m)) *
                     factor[3];
    if (e.gap) {  // across a gap the input says little
      sigma_t *= 100;
      sigma_r *= 100;
    }
    const ceres::ResidualBlockId id = Q.AddResidualBlock(
        RelativeMotionCost::Create(node_input_[e.from].inverse() * node_input_[e.to], sigma_t,
                                   sigma_r, options_.drift_vertical_ratio * factor[1] / factor[0],
                                   options_.drift_tilt_ratio * factor[2] / factor[3]),
        nullptr, nodes_[e.from].data(), nodes_[e.to].data(), &scales_[e.segment]);
    if (!e.gap) {
      drift_residuals_.push_back(
          {id, {nodes_[e.from].data(), nodes_[e.to].data(), &scales_[e.segment]}, false});
    }
    if (verbose_) group_blocks_[0].push_back(id);
  }
  for (const std::size_t k : smooth_middles_) {
    for (std::size_t j = k - 1; j <= k + 1; ++j) addNode(j);
    const double h0 = nsToSeconds(node_t_[k] - node_t_[k - 1]);
    const double h1 = nsToSeconds(node_t_[k + 1] - node_t_[k]);
    const double root = std::sqrt((h0 + h1) / 3);  // white-noise acceleration
    const ceres::ResidualBlockId id = Q.AddResidualBlock(
        SmoothMotionCost::Create(
            h0, h1, options_.between_samples_velocity_walk_mps_per_sqrt_s * root * factor[4],
            options_.between_samples_rate_walk_dps_per_sqrt_s * kDeg * root * factor[5]),
        nullptr, nodes_[k - 1].data(), nodes_[k].data(), nodes_[k + 1].data());
    drift_residuals_.push_back(
        {id, {nodes_[k - 1].data(), nodes_[k].data(), nodes_[k + 1].data()}, true});
    if (verbose_) group_blocks_[0].push_back(id);
  }
  for (std::size_t j = 0; j < n_segments_; ++j) {
    if (j > 0) {
      Q.AddResidualBlock(
          ScaleWalkCost::Create(options_.scale_walk_sigma * (visual_ ? scale0_ : 1.0)), nullptr,
          &scales_[j - 1], &scales_[j]);
    }
    if (!visual_) {
      Q.AddResidualBlock(ScalarPriorCost::Create(1.0, options_.metric_scale_sigma), nullptr,
                         &scales_[j]);
    }
  }
}

// fisheye_from_marker and its priors.
void JointAdjustment::addFisheyeFromMarker() {
  ceres::Problem& Q = *ceres_problem_;
  Q.AddParameterBlock(x_params_, 7, newPoseManifold());
  for (int c = 0; c < 6; ++c) {
    if (!prior_on_[c]) continue;
    const double sigma =
        c < 3 ? options_.prior_translation_sigma_m : options_.prior_rotation_sigma_deg * kDeg;
    Q.AddResidualBlock(ComponentPriorCost::Create(*problem_.fisheye_from_marker, c, sigma), nullptr,
                       x_params_);
  }
}

// A camera the clock search restarted may have a clock tens of ms off
// that its detections agreed with at the configured offset (one pass in one
// direction): once the solve takes it 5 ms or more from there, against the
// synchronised prior, its own prior is the unsynchronised one.
bool JointAdjustment::unsynchronised(const JointCamera& c) const {
  return c.unsynchronised ||
         (restarted_.count(c.registration->label) > 0 &&
          std::abs(c.offset_s - c.offset0_s) >= JointCamera::kUnsynchronisedFrom_s);
}

// Cameras, their clock offsets (with their priors) and their detections.
void JointAdjustment::addCamerasAndDetections() {
  ceres::Problem& Q = *ceres_problem_;
  for (JointCamera& c : cameras_) {
    Q.AddParameterBlock(c.pose, 7, newPoseManifold());
    Q.AddParameterBlock(&c.offset_s, 1);
    Q.AddResidualBlock(
        ScalarPriorCost::Create(c.offset0_s, unsynchronised(c)
                                                 ? options_.unsynchronised_clock_prior_sigma_s
                                                 : options_.clock_prior_sigma_s),
        nullptr, &c.offset_s);
    if (!options_.estimate_clock_offsets) Q.SetParameterBlockConstant(&c.offset_s);
    if (c.prior) {
      Q.AddResidualBlock(PosePriorCost::Create(*c.prior, c.prior_sqrt_info), nullptr, c.pose);
    }
  }
  for (std::size_t i = 0; i < detections_.size(); ++i) {
    const Detection& d = detections_[i];
    if (!d.in_range || !d.inlier) continue;
    const Bracket& b = *det_bracket_[i];
    addNode(b.k);
    addNode(b.k + 1);
    const ceres::ResidualBlockId id =
        Q.AddResidualBlock(markerCost(i), huber_.get(), nodes_[b.k].data(), nodes_[b.k + 1].data(),
                           x_params_, cameras_[d.camera].pose, &cameras_[d.camera].offset_s);
    marker_blocks_.emplace_back(id, i);
    if (verbose_) group_blocks_[1].push_back(id);
  }
}

// Each camera's associated blobs (at least min_blobs; at most
// max_blobs_per_camera, evenly spread, fewer in a drift round).
void JointAdjustment::addBlobs(bool drift_update_follows) {
  ceres::Problem& Q = *ceres_problem_;
  std::vector<std::size_t> frame_slot(frames_.size(), SIZE_MAX);
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const std::size_t n = matches_[c].size();
    cameras_[c].blobs = static_cast<int>(n);
    if (static_cast<int>(n) < options_.min_blobs) continue;
    std::size_t keep = options_.max_blobs_per_camera > 0
                           ? std::min(n, static_cast<std::size_t>(options_.max_blobs_per_camera))
                           : n;
    if (drift_update_follows && options_.drift_round_max_blobs_per_camera > 0) {
      keep = std::min(keep, static_cast<std::size_t>(options_.drift_round_max_blobs_per_camera));
    }
    for (std::size_t q = 0; q < keep; ++q) {
      const BlobMatch& m = matches_[c][q * n / keep];
      const BlobFrame& f = frames_[m.frame];
      double* nk = nodes_[f.bracket.k].data();
      double* nk1 = nodes_[f.bracket.k + 1].data();
      if (frame_slot[m.frame] == SIZE_MAX) {
        frame_slot[m.frame] = frame_poses_->add(f.bracket, nk, nk1);
      }
      auto* cost = new CachedBlobCost(
          frame_poses_.get(), frame_slot[m.frame], fisheye_, options_.blob_offset_in_camera_m,
          Eigen::Vector2d(f.blobs->blobs[m.blob].u, f.blobs->blobs[m.blob].v),
          options_.blob_sigma_px);
      addNode(f.bracket.k);
      addNode(f.bracket.k + 1);
      const ceres::ResidualBlockId id =
          Q.AddResidualBlock(cost, cauchy_.get(), nk, nk1, cameras_[c].pose);
      blob_blocks_.push_back({id, c, f.blobs->t});
      if (verbose_) group_blocks_[2].push_back(id);
    }
  }
}

// The elimination order of J^T J (fill_reducing_ordering.h); null = Ceres'
// own AMD. With `auto` the choice is made on the first round and again
// whenever the number of residual blocks changes by more than 5 % (the drift
// rounds' 60 blobs per camera, then all of them): in between the pattern is
// the same but for a few rejected detections, and the choice is kept,
// without the cost of the other ordering.
void JointAdjustment::chooseOrdering() {
  ceres::Problem& Q = *ceres_problem_;
  ordering_note_.clear();
  solver_.linear_solver_ordering.reset();
  if (solver_.linear_solver_type != ceres::SPARSE_NORMAL_CHOLESKY ||
      fill_method_ == FillOrderingMethod::kAmd) {
    return;
  }
  const double residuals = static_cast<double>(Q.NumResidualBlocks());
  FillOrderingMethod method = fill_method_;
  if (fill_method_ == FillOrderingMethod::kAuto && ordering_choice_.made &&
      std::abs(residuals - ordering_choice_.residuals) <= 0.05 * ordering_choice_.residuals) {
    method = ordering_choice_.method;
  }
  FillOrdering chosen;
  std::string message;
  const double ordering_start = processCpuSeconds();
  if (method != FillOrderingMethod::kAmd) {
    solver_.linear_solver_ordering = solverOrdering(Q, method, &chosen, &message);
  }
  const double ordering_cpu = processCpuSeconds() - ordering_start;
  const std::string warning = "joint: " + message + "; Ceres' own ordering was used";
  if (!message.empty() &&
      std::find(result_.notes.begin(), result_.notes.end(), warning) == result_.notes.end()) {
    result_.notes.push_back(warning);  // once, not every round
  }
  if (method == FillOrderingMethod::kAuto) ordering_choice_ = {true, residuals, chosen.method};
  if (verbose_) {
    std::ostringstream o;
    o << "; ordering " << fillOrderingMethodName(chosen.method)
      << (method == fill_method_ ? "" : " (kept)") << " (CPU " << ordering_cpu << " s)";
    if (chosen.predicted_flops > 0) o << ", predicted " << chosen.predicted_flops << " flops";
    if (chosen.predicted_flops_other > 0) o << " (other " << chosen.predicted_flops_other << ")";
    ordering_note_ = o.str();
  }
}

void JointAdjustment::prepareFramePoses() { frame_poses_->PrepareForEvaluation(true, true); }

void JointAdjustment::solveRound(int round, bool drift_update_follows) {
  const double cpu_setup = lap();
  ceres::Solver::Summary summary;
  // Rounds before the last only prepare the next association, outlier
  // rejection and weights: they stop at early_round_max_iterations.
  const bool last_round = round + 1 == max_rounds_;
  solver_.max_num_iterations =
      last_round || options_.early_round_max_iterations == 0
          ? options_.max_iterations
          : std::min(options_.max_iterations, options_.early_round_max_iterations);
  previous_short_ =
      drift_update_follows && drift_.updates > 0 && options_.drift_round_max_iterations > 0;
  if (previous_short_) {
    solver_.max_num_iterations =
        std::min(solver_.max_num_iterations, options_.drift_round_max_iterations);
  }
  const Snapshot before = verbose_ ? snapshot() : Snapshot();
  serialiseOpenMpInThisThread();  // CHOLMOD's teams of 4 (core/threads.h)
  ceres::Solve(solver_, ceres_problem_.get(), &summary);
  if (verbose_) reportMoves(round, before);
  previous_converged_ = summary.termination_type == ceres::CONVERGENCE;
  if (verbose_) reportRound(round, summary, cpu_setup);
  if (!summary.IsSolutionUsable()) {
    throw Error("joint: the solver failed: " + summary.message);
  }
}

JointAdjustment::Snapshot JointAdjustment::snapshot() const {
  Snapshot s;
  s.nodes = nodes_;
  for (const JointCamera& c : cameras_) {
    s.cameras.emplace_back();
    std::copy(c.pose, c.pose + 7, s.cameras.back().begin());
    s.offsets.push_back(c.offset_s);
  }
  s.scales = scales_;
  std::copy(x_params_, x_params_ + 7, s.x.begin());
  return s;
}

void JointAdjustment::reportMoves(int round, const Snapshot& before) const {
  auto moved = [](const double* a, const double* b) {
    const double t = (Eigen::Vector3d(a[0], a[1], a[2]) - Eigen::Vector3d(b[0], b[1], b[2])).norm();
    const Eigen::Quaterniond qa(a[6], a[3], a[4], a[5]), qb(b[6], b[3], b[4], b[5]);
    return std::make_pair(t, qa.angularDistance(qb) / kDeg);
  };
  double node_t = 0, node_r = 0, camera_t = 0, camera_r = 0, clock = 0, scale = 0;
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    const auto [t, r] = moved(nodes_[k].data(), before.nodes[k].data());
    node_t = std::max(node_t, t);
    node_r = std::max(node_r, r);
  }
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const auto [t, r] = moved(cameras_[c].pose, before.cameras[c].data());
    camera_t = std::max(camera_t, t);
    camera_r = std::max(camera_r, r);
    clock = std::max(clock, std::abs(cameras_[c].offset_s - before.offsets[c]));
  }
  for (std::size_t j = 0; j < scales_.size(); ++j) {
    scale = std::max(scale, std::abs(scales_[j] - before.scales[j]));
  }
  const auto [x_t, x_r] = moved(x_params_, before.x.data());
  std::cerr << "joint round " << round + 1 << ": largest moves: node " << node_t << " m, " << node_r
            << " deg; camera " << camera_t << " m, " << camera_r << " deg; clock " << clock * 1e3
            << " ms; scale " << scale << "; fisheye_from_marker " << x_t << " m, " << x_r
            << " deg\n";
}

void JointAdjustment::reportRound(int round, const ceres::Solver::Summary& summary,
                                  double cpu_setup) {
  ceres::Problem& Q = *ceres_problem_;
  std::cerr << "joint round " << round + 1 << ": CPU " << cpu_setup << " s association and setup, "
            << lap() << " s solve (preprocessor " << summary.preprocessor_time_in_seconds
            << " s wall, residuals " << summary.residual_evaluation_time_in_seconds
            << " s wall): " << summary.BriefReport() << " residual blocks " << Q.NumResidualBlocks()
            << ", time " << summary.total_time_in_seconds << " s (jacobians "
            << summary.jacobian_evaluation_time_in_seconds << " s, linear solver "
            << summary.linear_solver_time_in_seconds << " s)" << ordering_note_ << "\n";
  if (round == 0 || verbose_every_round_) std::cerr << summary.FullReport() << "\n";
  std::cerr << "joint round " << round + 1 << ": final cost of odometry, markers, blobs:";
  for (const auto& ids : group_blocks_) {
    ceres::Problem::EvaluateOptions eo;
    eo.residual_blocks = ids;
    double group_cost = 0;
    Q.Evaluate(eo, &group_cost, nullptr, nullptr, nullptr);
    std::cerr << " " << group_cost << " (" << ids.size() << " blocks)";
  }
  std::cerr << "\n";
}

}  // namespace lookboth::joint_detail
