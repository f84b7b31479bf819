// Stage `joint`: the results written into the problem and its Registration
// (joint_adjustment.h): the covariance (the gauge: the first node is
// constant), fisheye_from_marker, the scale, the corrected trajectory, each
// camera, and the fisheye reprojection of the camera positions.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <set>
#include <sstream>

#include "joint_adjustment.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/time.h"

namespace lookboth::joint_detail {
namespace {

const char* kComponentNames[6] = {
    "x", "y", "z", "roll (about x)", "pitch (about y)", "yaw (about z)"};

void appendSentence(std::string& message, const std::string& sentence) {
  message += (message.empty() ? "" : " ") + sentence;
}

}  // namespace

// The drift model and the marker variance factors the rounds estimated.
void JointAdjustment::noteModelEstimates() {
  if (options_.estimate_drift_model && !options_.fix_trajectory) {
    DriftModelEstimate e;
    e.horizontal = drift_.factor[0];
    e.vertical = drift_.factor[1];
    e.tilt = drift_.factor[2];
    e.yaw = drift_.factor[3];
    e.updates = drift_.updates;
    const bool between_samples = std::any_of(node_between_samples_.begin(),
                                             node_between_samples_.end(), [](bool b) { return b; });
    if (between_samples) {
      e.between_samples_velocity_walk = drift_.factor[4];
      e.between_samples_rate_walk = drift_.factor[5];
    }
    result_.observability.drift_model = e;
    auto sigmaFactor = [](double f) { return formatFixed(f, f < 0.1 ? 3 : 2); };
    appendSentence(
        result_.observability.message,
        std::string("joint: the drift model estimated from the data (") +
            std::to_string(drift_.updates) + " updates" +
            (drift_.still_changing ? ", the last still changing it by more than 10 %" : "") +
            ") is the configured one with its sigmas times " + sigmaFactor(e.horizontal) +
            " horizontally, " + sigmaFactor(e.vertical) + " vertically, " + sigmaFactor(e.tilt) +
            " in tilt and " + sigmaFactor(e.yaw) + " in yaw" +
            (between_samples
                 ? ", and the smooth motion between the input's samples' velocity walk " +
                       sigmaFactor(drift_.factor[4]) + " and angular rate walk " +
                       sigmaFactor(drift_.factor[5])
                 : std::string()) +
            ".");
  }
  for (int kind = 0; kind < 2; ++kind) {
    if (variance_factor_[kind] > 1.5) {
      std::ostringstream w;
      w << std::setprecision(3) << "joint: the marker " << (kind ? "corners'" : "poses'")
        << " residuals are " << variance_factor_[kind]
        << "x (in variance) what the detector's covariance says (median chi-square); they were "
           "weighted and rejected with that factor";
      result_.notes.push_back(w.str());
    }
  }
}

// What each camera used; a camera with too few is held constant, out of the
// covariance.
void JointAdjustment::countDetections() {
  used_.assign(cameras_.size(), 0);
  rejected_.assign(cameras_.size(), 0);
  for (const Detection& d : detections_) {
    if (!d.in_range) continue;
    (d.inlier ? used_ : rejected_)[d.camera]++;
  }
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    if (used_[c] < options_.min_detections) {
      ceres_problem_->SetParameterBlockConstant(cameras_[c].pose);
      ceres_problem_->SetParameterBlockConstant(&cameras_[c].offset_s);
    }
  }
}

void JointAdjustment::computeCovariance() {
  const bool scales_free = !options_.fix_trajectory;
  std::vector<std::pair<const double*, const double*>> blocks;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    if (used_[c] < options_.min_detections) continue;
    blocks.emplace_back(cameras_[c].pose, cameras_[c].pose);
    if (options_.estimate_clock_offsets) {
      blocks.emplace_back(&cameras_[c].offset_s, &cameras_[c].offset_s);
    }
  }
  // Every pair of camera poses too, for the gauge-free prediction (the pairs
  // are dense: their cost grows like the cube of the cameras).
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    if (used_[c] >= options_.min_detections) aligned_cameras_.push_back(c);
  }
  aligned_prediction_ =
      aligned_cameras_.size() >= 3 &&
      aligned_cameras_.size() <= static_cast<std::size_t>(options_.aligned_uncertainty_max_cameras);
  if (aligned_prediction_) {
    for (std::size_t a = 0; a < aligned_cameras_.size(); ++a) {
      for (std::size_t b = a + 1; b < aligned_cameras_.size(); ++b) {
        blocks.emplace_back(cameras_[aligned_cameras_[a]].pose, cameras_[aligned_cameras_[b]].pose);
      }
    }
  }
  if (!options_.fix_fisheye_from_marker) blocks.emplace_back(x_params_, x_params_);
  scale_covariance_ = visual_ && scales_free && n_segments_ <= 200;
  if (scale_covariance_) {
    for (std::size_t i = 0; i < n_segments_; ++i) {
      for (std::size_t j = i; j < n_segments_; ++j) blocks.emplace_back(&scales_[i], &scales_[j]);
    }
  }
  if (options_.covariance && !blocks.empty()) {
    progress_.report("joint", max_rounds_, max_rounds_, "covariance");
    prepareFramePoses();  // (Problem::Evaluate calls it too)
    lap();
    std::vector<const double*> whole;
    if (options_.shared_errors_through_trajectory && aligned_prediction_) {
      for (const std::size_t c : aligned_cameras_) whole.push_back(cameras_[c].pose);
    }
    covariance_.requestWholeColumns(whole);
    have_covariance_ = covariance_.compute(blocks, ceres_problem_.get(), options_.threads);
    if (verbose_) {
      std::cerr << "joint covariance: CPU " << lap() << " s" << covariance_.describe() << "\n";
    }
    if (!have_covariance_) {
      result_.warnings.push_back("joint: the covariance could not be computed (" +
                                 covariance_.message() +
                                 "): the registration has no uncertainty; check the cameras "
                                 "with few detections");
    }
  }
  if (have_covariance_ && !computeSharedErrorSpread()) computePassCovariance();
  if (have_covariance_ && aligned_prediction_) computeAlignedPrediction();
}

// The detections of a pass share a part of their errors, which the residuals
// cannot show (the camera's pose absorbs it) and the covariance above leaves
// out. By the model `lookboth detect --evaluate` measures it in, a group of n
// measurements (a camera's marker detections, or the blobs of its housing,
// with no gap over pass_gap_s) whose errors share beta times each one's
// covariance has the information H_g of independent ones but an error whose
// covariance, mapped through them, is (1 + beta n) H_g: about beta n H_g more.
// Given the trajectory, the camera's pose moves by H^-1 J_g^T e_g for a
// group's errors e_g (H: its pose's information from all its residuals, at the
// solution, robust weights included), so its covariance gains
// H^-1 (sum_g beta_g n_g H_g) H^-1: a sandwich over the groups, with
// pass_error_share for the markers and blob_pass_error_share for the blobs.
void JointAdjustment::computePassCovariance() {
  pass_covariance_.clear();
  const double share[2] = {options_.pass_error_share, options_.blob_pass_error_share};
  if (!(share[0] > 0) && !(share[1] > 0)) return;
  prepareFramePoses();  // the blob costs' frame poses, as the covariance's
  const ceres::Problem& Q = *ceres_problem_;
  const std::vector<std::array<PassGroups, 2>> passes = passesByCamera();
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    double* pose = cameras_[c].pose;
    if (Q.IsParameterBlockConstant(pose)) continue;
    std::vector<ceres::ResidualBlockId> blocks;
    Q.GetResidualBlocksForParameterBlock(pose, &blocks);
    Matrix6d all = Matrix6d::Zero();
    for (ceres::ResidualBlockId id : blocks) all += informationOn(id, pose);
    const Eigen::LDLT<Matrix6d> h(all);
    if (h.info() != Eigen::Success) continue;
    Matrix6d middle = Matrix6d::Zero();
    for (int kind = 0; kind < 2; ++kind) {
      if (!(share[kind] > 0)) continue;
      for (const std::vector<ceres::ResidualBlockId>& pass : passes[c][kind]) {
        Matrix6d information = Matrix6d::Zero();
        for (const ceres::ResidualBlockId id : pass) information += informationOn(id, pose);
        middle += share[kind] * static_cast<double>(pass.size()) * information;
      }
    }
    const Matrix6d spread = h.solve(h.solve(middle).transpose());  // H^-1 M H^-1
    if (spread.allFinite()) pass_covariance_[c] = 0.5 * (spread + spread.transpose());
  }
}

std::vector<std::array<JointAdjustment::PassGroups, 2>> JointAdjustment::passesByCamera() const {
  struct Member {
    TimeNs t;
    ceres::ResidualBlockId id;
  };
  std::vector<std::array<std::vector<Member>, 2>> members(cameras_.size());
  for (const auto& [id, i] : marker_blocks_) {
    members[detections_[i].camera][0].push_back({detections_[i].t_camera, id});
  }
  for (const BlobBlock& b : blob_blocks_) members[b.camera][1].push_back({b.t, b.id});
  const TimeNs gap = secondsToNsRounded(options_.pass_gap_s);
  std::vector<std::array<PassGroups, 2>> passes(cameras_.size());
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    for (int kind = 0; kind < 2; ++kind) {
      std::vector<Member>& group = members[c][kind];
      std::sort(group.begin(), group.end(),
                [](const Member& a, const Member& b) { return a.t < b.t; });
      std::vector<TimeNs> times;
      for (const Member& m : group) times.push_back(m.t);
      for (const auto& [begin, end] : runsWithinGap(times, gap)) {
        std::vector<ceres::ResidualBlockId>& pass = passes[c][kind].emplace_back();
        for (std::size_t k = begin; k < end; ++k) pass.push_back(group[k].id);
      }
    }
  }
  return passes;
}

// The shared errors' effect on the cameras through the whole problem, not
// given the trajectory: a pass's errors move the path under it too, and the
// path carries them to the other cameras. The model is computePassCovariance's:
// a pass g of n residuals shares an error that acts as a perturbation d of its
// camera's pose, of covariance beta n H_g^-1 (H_g: the camera pose's
// information from the pass), reaching residual i as J_i^c d (J_i^c: its
// Jacobian with respect to that pose; whitened, robust weights applied). With
// J_i its Jacobian with respect to every parameter and H = J^T J at the
// solution, the estimate moves by H^-1 u_g d, u_g = sum_i J_i^T J_i^c, so the
// covariance gains H^-1 (sum_g beta n u_g H_g^-1 u_g^T) H^-1. Only the cameras'
// blocks are wanted: with Y = the cameras' columns of H^-1 (the covariance
// computation keeps them) and Z_g = u_g^T Y, the sum of beta n Z_g^T H_g^-1
// Z_g. Given the trajectory (u_g's camera rows alone) this is
// computePassCovariance's H^-1 (beta n H_g) H^-1. False when Y was not kept
// (then that one is used).
bool JointAdjustment::computeSharedErrorSpread() {
  spread_.resize(0, 0);
  spread_column_.clear();
  const Eigen::MatrixXd& Y = covariance_.wholeColumns();
  if (Y.cols() != 6 * static_cast<Eigen::Index>(aligned_cameras_.size())) return false;
  prepareFramePoses();  // the blob costs' frame poses, as the covariance's
  const double share[2] = {options_.pass_error_share, options_.blob_pass_error_share};
  spread_ = Eigen::MatrixXd::Zero(Y.cols(), Y.cols());
  for (std::size_t k = 0; k < aligned_cameras_.size(); ++k) spread_column_[aligned_cameras_[k]] = k;
  const std::vector<std::array<PassGroups, 2>> passes = passesByCamera();
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    for (int kind = 0; kind < 2; ++kind) {
      if (!(share[kind] > 0)) continue;
      for (const std::vector<ceres::ResidualBlockId>& pass : passes[c][kind]) {
        Matrix6d h = Matrix6d::Zero();
        const Eigen::MatrixXd z = passTimesColumns(pass, cameras_[c].pose, Y, &h);
        const Eigen::LDLT<Matrix6d> factor(h);
        if (factor.info() != Eigen::Success) continue;
        spread_ += share[kind] * static_cast<double>(pass.size()) * z.transpose() * factor.solve(z);
      }
    }
  }
  spread_ = 0.5 * (spread_ + spread_.transpose());
  return spread_.allFinite();
}

// Z_g = u_g^T Y = sum_i J_i^c^T (J_i Y) for one pass, and H_g = sum_i
// J_i^c^T J_i^c, from its residual blocks' Jacobians (tangents, robust
// weights applied); `pose` is the pass's camera.
Eigen::MatrixXd JointAdjustment::passTimesColumns(const std::vector<ceres::ResidualBlockId>& pass,
                                                  const double* pose, const Eigen::MatrixXd& Y,
                                                  Matrix6d* h) const {
  const ceres::Problem& Q = *ceres_problem_;
  Eigen::MatrixXd z = Eigen::MatrixXd::Zero(6, Y.cols());
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  for (const ceres::ResidualBlockId id : pass) {
    const int k = Q.GetCostFunctionForResidualBlock(id)->num_residuals();
    std::vector<double*> parameters;
    Q.GetParameterBlocksForResidualBlock(id, &parameters);
    std::vector<RowMajor> jacobian(parameters.size());
    std::vector<double*> pointers(parameters.size(), nullptr);
    int camera_block = -1;
    for (std::size_t b = 0; b < parameters.size(); ++b) {
      if (parameters[b] == pose) camera_block = static_cast<int>(b);
      if (covariance_.wholeRow(parameters[b]) < 0) continue;  // held constant
      jacobian[b].resize(k, Q.ParameterBlockTangentSize(parameters[b]));
      pointers[b] = jacobian[b].data();
    }
    std::vector<double> residuals(static_cast<std::size_t>(k));
    double cost = 0;
    if (camera_block < 0 || pointers[camera_block] == nullptr ||
        !Q.EvaluateResidualBlockAssumingParametersUnchanged(id, true, &cost, residuals.data(),
                                                            pointers.data())) {
      continue;
    }
    Eigen::MatrixXd jy = Eigen::MatrixXd::Zero(k, Y.cols());
    for (std::size_t b = 0; b < parameters.size(); ++b) {
      if (pointers[b] == nullptr) continue;
      jy.noalias() +=
          jacobian[b] * Y.middleRows(covariance_.wholeRow(parameters[b]), jacobian[b].cols());
    }
    const RowMajor& jc = jacobian[camera_block];
    z.noalias() += jc.transpose() * jy;
    *h += jc.transpose() * jc;
  }
  return z;
}

// J^T J of a residual block's Jacobian with respect to one of its pose
// blocks: Ceres returns it in the pose's tangent, with the loss function
// applied.
Matrix6d JointAdjustment::informationOn(ceres::ResidualBlockId id, double* block) const {
  const ceres::Problem& Q = *ceres_problem_;
  std::vector<double*> parameters;
  Q.GetParameterBlocksForResidualBlock(id, &parameters);
  const int rows = Q.GetCostFunctionForResidualBlock(id)->num_residuals();
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> tangent(rows, 6);
  std::vector<double*> jacobians(parameters.size(), nullptr);
  for (std::size_t k = 0; k < parameters.size(); ++k) {
    if (parameters[k] == block) jacobians[k] = tangent.data();
  }
  std::vector<double> residuals(static_cast<std::size_t>(rows));
  double cost = 0;
  // (The frame poses the blob costs read are prepared once, by the caller:
  // EvaluateResidualBlock would prepare all of them for every block.)
  if (!Q.EvaluateResidualBlockAssumingParametersUnchanged(id, true, &cost, residuals.data(),
                                                          jacobians.data()) ||
      !tangent.allFinite()) {
    return Matrix6d::Zero();
  }
  return tangent.transpose() * tangent;
}

Matrix6d JointAdjustment::passCovariance(std::size_t a, std::size_t b) const {
  const auto ia = spread_column_.find(a), ib = spread_column_.find(b);
  if (ia != spread_column_.end() && ib != spread_column_.end()) {
    return spread_.block<6, 6>(6 * ia->second, 6 * ib->second);
  }
  if (a != b) return Matrix6d::Zero();
  const auto found = pass_covariance_.find(a);
  return found == pass_covariance_.end() ? Matrix6d::Zero() : found->second;
}

// The cameras' position RMSE the covariance predicts after a rigid alignment
// to any reference (what `lookboth evaluate` reports as aligned): the
// positions' joint covariance C with the linearised alignment (dp_i = t + w x
// p_i, least squares over the cameras) projected out, sqrt(trace(P C P) / n)
// with P = I - A (A^T A)^-1 A^T.
void JointAdjustment::computeAlignedPrediction() {
  const std::size_t n = aligned_cameras_.size();
  Eigen::MatrixXd C(3 * n, 3 * n), A(3 * n, 6);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (std::size_t c : aligned_cameras_)
    centroid += Eigen::Map<const Eigen::Vector3d>(cameras_[c].pose);
  centroid /= static_cast<double>(n);
  for (std::size_t a = 0; a < n; ++a) {
    const double* pa = cameras_[aligned_cameras_[a]].pose;
    for (std::size_t b = a; b < n; ++b) {
      Eigen::Matrix3d block =
          covariance_.block(pa, cameras_[aligned_cameras_[b]].pose).topLeftCorner<3, 3>();
      block += passCovariance(aligned_cameras_[a], aligned_cameras_[b]).topLeftCorner<3, 3>();
      C.block<3, 3>(3 * a, 3 * b) = block;
      C.block<3, 3>(3 * b, 3 * a) = block.transpose();
    }
    const Eigen::Vector3d p = Eigen::Map<const Eigen::Vector3d>(pa) - centroid;
    A.block<3, 3>(3 * a, 0).setIdentity();
    A.block<3, 3>(3 * a, 3) << 0, p.z(), -p.y(), -p.z(), 0, p.x(), p.y(), -p.x(), 0;  // -[p]x
  }
  const Eigen::MatrixXd P =
      Eigen::MatrixXd::Identity(3 * n, 3 * n) - A * (A.transpose() * A).ldlt().solve(A.transpose());
  const Eigen::MatrixXd aligned = P * C * P.transpose();
  result_.observability.aligned_position_rmse_m =
      std::sqrt(std::max(0.0, aligned.trace() / static_cast<double>(n)));
  for (std::size_t a = 0; a < n; ++a) {
    aligned_position_covariance_[aligned_cameras_[a]] = aligned.block<3, 3>(3 * a, 3 * a);
  }
}

void JointAdjustment::writeFisheyeFromMarker() {
  const Rigid3d X = paramsToPose(x_params_);
  problem_.fisheye_from_marker = X;
  result_.fisheye_from_marker = X;
  std::vector<std::string> notes;
  if (options_.fix_fisheye_from_marker) {
    notes.push_back(std::string("joint: fisheye_from_marker held fixed at ") +
                    (options_.fisheye_from_marker_from_ground_truth
                         ? "the dataset's ground truth"
                         : "the value of the earlier stages") +
                    " (fix_fisheye_from_marker)");
  } else if (have_covariance_) {
    const Matrix6d cov = covariance_.block(x_params_, x_params_);
    result_.fisheye_from_marker_covariance = cov;
    std::string undetermined;  // components the data leaves to a prior or free
    bool free_component = false;
    for (int c = 0; c < 6; ++c) {
      const double sigma = std::sqrt(std::max(0.0, cov(c, c)));
      const double prior_sigma =
          c < 3 ? options_.prior_translation_sigma_m : options_.prior_rotation_sigma_deg * kDeg;
      const double max_sigma =
          c < 3 ? options_.max_translation_sigma_m : options_.max_rotation_sigma_deg * kDeg;
      const bool by_prior = prior_on_[c] && sigma > 0.5 * prior_sigma;
      const bool determined = sigma <= max_sigma && !by_prior;
      result_.fisheye_from_marker_determined[c] = determined;
      if (determined) continue;
      // Loosely known is worth a note; a warning when the cameras move with
      // it by more than centimetres (or degrees).
      free_component = free_component || (!by_prior && sigma > kLooseFactor * max_sigma);
      undetermined +=
          std::string(undetermined.empty() ? "" : ", ") + kComponentNames[c] + " (sigma " +
          (c < 3 ? formatFixed(sigma * 1000, 2) + " mm" : formatFixed(sigma / kDeg, 3) + " deg") +
          (by_prior ? ", held by the prior of motion_calibration" : "") + ")";
    }
    if (undetermined.empty()) {
      notes.push_back(
          "joint: the detections and blobs determine every component of fisheye_from_marker" +
          std::string(std::any_of(prior_on_.begin(), prior_on_.end(), [](bool b) { return b; })
                          ? " (the motion-only priors no longer dominate)"
                          : ""));
    } else {
      notes.push_back("joint: not determined by the data: fisheye_from_marker " + undetermined);
      if (free_component) {
        // Nothing holds it: the cameras move with its arbitrary value.
        result_.warnings.push_back(
            "joint: fisheye_from_marker " + undetermined +
            " is not determined by the data and no prior holds it: measure the marker's "
            "mount on the robot and set register.motion_calibration.prior_translation_m / "
            "prior_rotation_xyzw, or drive with more turns and slopes");
      } else {
        // A flat floor cannot determine the marker's height (or tilt):
        // expected, and the configured mount then decides it.
        result_.notes.push_back("joint: fisheye_from_marker " + undetermined +
                                ": loosely determined, or held by the configured mount where a "
                                "flat floor cannot determine it (expected)");
      }
    }
  }
  for (const std::string& n : notes) appendSentence(result_.observability.message, n + ".");
}

// Visual mode: the mean of the segments' scales, its sigma, and their range.
void JointAdjustment::writeScale() {
  if (!visual_) return;
  double mean = 0;
  for (double s : scales_) mean += s;
  mean /= static_cast<double>(n_segments_);
  problem_.scale = mean;
  result_.scale = mean;
  if (have_covariance_ && scale_covariance_) {
    double var = 0;
    for (std::size_t i = 0; i < n_segments_; ++i) {
      for (std::size_t j = 0; j < n_segments_; ++j) {
        var += covariance_.block(&scales_[std::min(i, j)], &scales_[std::max(i, j)])(0, 0);
      }
    }
    result_.scale_sigma = std::sqrt(std::max(0.0, var)) / static_cast<double>(n_segments_);
  }
  const double lo = *std::min_element(scales_.begin(), scales_.end());
  const double hi = *std::max_element(scales_.begin(), scales_.end());
  if (n_segments_ > 1) {
    appendSentence(result_.observability.message,
                   std::string("joint: the trajectory's scale varies over ") +
                       std::to_string(n_segments_) + " segments of " +
                       formatDouble(options_.scale_segment_m) + " m from " + formatFixed(lo, 6) +
                       " to " + formatFixed(hi, 6) + ".");
  }
}

// The corrected trajectory at the input's samples between the nodes and at
// the nodes added between them.
void JointAdjustment::writeTrajectory() {
  std::vector<TimeNs> times;
  times.reserve(samples_->size() + nodes_.size());
  for (const StampedPose& sample : *samples_) times.push_back(sample.t);
  for (std::size_t k = 0; k < nodes_.size(); ++k) {
    if (node_between_samples_[k]) times.push_back(node_t_[k]);
  }
  std::sort(times.begin(), times.end());
  std::vector<StampedPose> corrected;
  corrected.reserve(times.size());
  for (const TimeNs t : times) {
    const auto b = bracketAt(t, false);
    if (!b) continue;
    corrected.push_back({t, evalPose(*b, b->tau_ref_s)});
  }
  problem_.metric_trajectory = std::move(corrected);
}

// A camera's pose, covariance, clock offset, residuals and status.
void JointAdjustment::writeCamera(std::size_t c) {
  JointCamera& jc = cameras_[c];
  CameraRegistration& camera = *jc.registration;
  std::vector<std::size_t>& kept = problem_.inliers_by_camera[camera.label];
  kept.clear();
  const int n = used_[c] + rejected_[c];
  camera.detections.used = used_[c];
  camera.detections.rejected = rejected_[c];
  if (used_[c] < options_.min_detections) {
    camera.status = CameraStatus::kUnregistered;
    camera.reason = "joint: only " + std::to_string(used_[c]) + " of " + std::to_string(n) +
                    " detections are consistent with the joint estimate (at least " +
                    std::to_string(options_.min_detections) + " needed)";
    camera.covariance.reset();
    camera.aligned_position_covariance.reset();
    camera.residuals.reset();
    return;
  }
  if (restarted_.count(camera.label)) {
    camera.notes.push_back("joint: registered although look_down was not (" + camera.reason + ")");
  }
  const Rigid3d pose = paramsToPose(jc.pose);
  camera.world_from_camera = pose;
  camera.stage_poses["joint"] = pose;
  camera.covariance.reset();
  if (have_covariance_) {
    camera.covariance = Matrix6d(covariance_.block(jc.pose, jc.pose)) + passCovariance(c, c);
  }
  camera.aligned_position_covariance.reset();
  if (const auto found = aligned_position_covariance_.find(c);
      found != aligned_position_covariance_.end()) {
    camera.aligned_position_covariance = found->second;
  }
  ClockOffsetEstimate offset;
  offset.offset_ns = static_cast<TimeNs>(std::llround(jc.offset_s * 1e9));
  offset.estimated = options_.estimate_clock_offsets;
  if (have_covariance_ && options_.estimate_clock_offsets) {
    const double variance = covariance_.block(&jc.offset_s, &jc.offset_s)(0, 0);
    offset.sigma_ms = std::sqrt(std::max(0.0, variance)) * 1e3;
    if (offset.sigma_ms > options_.max_clock_sigma_ms) {
      camera.warnings.push_back(
          "joint: the clock offset is uncertain (sigma " + formatFixed(offset.sigma_ms, 1) +
          " ms, more than max_clock_sigma_ms " + formatFixed(options_.max_clock_sigma_ms, 1) +
          " ms): the robot passed too few times or too slowly under the camera; drive under "
          "it again, or synchronise its clock and set estimate_clock_offsets: false");
    }
  }
  camera.clock_offset = offset;
  // Off by more than its own uncertainty can explain: the camera's clock is
  // wrong. The registration corrected for it; the clock itself needs fixing.
  const double clock_change_ms = (jc.offset_s - jc.offset0_s) * 1e3;
  if (std::abs(clock_change_ms) > std::max(kMinClockChangeMs, 3 * offset.sigma_ms)) {
    camera.warnings.push_back(
        "joint: clock offset " + formatFixed(jc.offset_s * 1e3, 1) + " ms (node - robot) +- " +
        formatFixed(offset.sigma_ms, 1) + " ms estimated; configured " +
        formatFixed(jc.offset0_s * 1e3, 1) +
        " ms: the registration corrected for it; fix the camera's time synchronisation, or "
        "set register.associate.clock_offsets_ns for it");
  }
  // Residuals as look_down reports them (marker pose by the camera vs by the robot).
  const Rigid3d X = paramsToPose(x_params_);
  double sum_p = 0, sum_r = 0;
  for (std::size_t i : jc.detections) {
    const Detection& d = detections_[i];
    if (!d.in_range || !d.inlier) continue;
    kept.push_back(d.association);
    const Bracket& b = *det_bracket_[i];
    const double tau = nsToSeconds(d.t_camera - node_t_[b.k]) - jc.offset_s;
    const Rigid3d by_robot = evalPose(b, tau) * X;
    const Rigid3d by_camera =
        pose * problem_.marker(problem_.associations[d.association]).camera_from_marker;
    sum_p += (by_camera.translation - by_robot.translation).squaredNorm();
    const double angle = calib_detail::angleOf(by_camera.rotation.conjugate() * by_robot.rotation);
    sum_r += angle * angle;
  }
  camera.residuals = ResidualStats{std::sqrt(sum_p / used_[c]), std::sqrt(sum_r / used_[c]) / kDeg};
  const double rejected_fraction = n > 0 ? static_cast<double>(rejected_[c]) / n : 0.0;
  if (rejected_fraction > 0.3) {
    camera.status = CameraStatus::kSuspect;
    camera.reason = "joint: " + std::to_string(rejected_[c]) + " of " + std::to_string(n) +
                    " detections disagree with the joint estimate";
  } else if (used_[c] < 8) {
    camera.status = CameraStatus::kSuspect;
    camera.reason = "only " + std::to_string(used_[c]) + " consistent detections";
  } else {
    camera.status = CameraStatus::kRegistered;
    camera.reason.clear();
  }
  if (jc.blobs > 0 && jc.blobs < options_.min_blobs) {
    camera.notes.push_back("joint: only " + std::to_string(jc.blobs) +
                           " blobs associated; not used");
  }
}

// The paper's Table I for the final result: "before" = look_down's position
// on the input trajectory (motion_calibration's scale), "after" = the joint
// estimate on the corrected trajectory, over the blobs associated at the
// joint estimate. They replace look_up's statistics and rows of
// blob_associations.csv for the cameras of this stage.
void JointAdjustment::writeReprojection() {
  associateBlobs();
  auto projectFrom = [&](const Rigid3d& world_from_fisheye,
                         const Eigen::Vector3d& p_in_world) -> std::optional<Eigen::Vector2d> {
    const Eigen::Vector3d p = world_from_fisheye.inverse() * p_in_world;
    if (p.z() <= 0) return std::nullopt;
    return fisheye_->project(p);
  };
  std::set<std::string> labels;
  std::vector<BlobAssociation> rows;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    CameraRegistration& camera = *cameras_[c].registration;
    labels.insert(camera.label);
    camera.reprojection.reset();
    if (camera.status == CameraStatus::kUnregistered) continue;
    const auto look_down = camera.stage_poses.find("look_down");
    const Rigid3d before_pose =
        look_down != camera.stage_poses.end() ? look_down->second : cameras_[c].start;
    const Eigen::Vector3d before_in_world = before_pose * options_.blob_offset_in_camera_m;
    const Eigen::Vector3d after_in_world =
        camera.world_from_camera * options_.blob_offset_in_camera_m;
    int n = 0;
    double sum_before = 0, sum_after = 0;
    for (const BlobMatch& m : matches_[c]) {
      const BlobFrame& f = frames_[m.frame];
      const Blob& blob = f.blobs->blobs[m.blob];
      const auto before = projectFrom(f.bracket.reference, before_in_world);
      const auto after = projectFrom(evalPose(f.bracket, f.bracket.tau_ref_s), after_in_world);
      if (!before || !after) continue;
      const Eigen::Vector2d observed(blob.u, blob.v);
      sum_before += (*before - observed).squaredNorm();
      sum_after += (*after - observed).squaredNorm();
      ++n;
      rows.push_back({f.blobs->t, camera.label, blob.u, blob.v, before->x(), before->y(),
                      after->x(), after->y()});
    }
    if (n == 0) continue;
    camera.reprojection =
        ReprojectionStats{n, std::sqrt(sum_before / n), std::sqrt(sum_after / n), "joint"};
  }
  std::vector<BlobAssociation>& all = result_.blob_associations;
  all.erase(std::remove_if(all.begin(), all.end(),
                           [&](const BlobAssociation& a) { return labels.count(a.camera) > 0; }),
            all.end());
  all.insert(all.end(), rows.begin(), rows.end());
  std::sort(all.begin(), all.end(), [](const BlobAssociation& a, const BlobAssociation& b) {
    return a.t != b.t ? a.t < b.t : a.camera < b.camera;
  });
  // Totals over every camera that has statistics (this stage's, and
  // look_up's of cameras the stage did not take).
  int blobs = 0;
  double before2 = 0, after2 = 0;
  for (const CameraRegistration& camera : result_.cameras) {
    if (!camera.reprojection || camera.reprojection->blobs == 0) continue;
    const ReprojectionStats& st = *camera.reprojection;
    blobs += st.blobs;
    before2 += st.rms_px_before * st.rms_px_before * st.blobs;
    after2 += st.rms_px_after * st.rms_px_after * st.blobs;
  }
  if (blobs > 0) {
    result_.reprojection =
        ReprojectionStats{blobs, std::sqrt(before2 / blobs), std::sqrt(after2 / blobs), "joint"};
  } else {
    result_.reprojection.reset();
  }
}

}  // namespace lookboth::joint_detail
