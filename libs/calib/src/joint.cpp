// Stage `joint` (issue #10, beyond the paper): one Ceres problem over
//   - trajectory nodes N_k = world_from_fisheye (metric) at input samples at
//     least node_interval_s apart, tied by the input's relative motions
//     weighted by a drift model (sigma^2 = min^2 + drift^2 * distance) and a
//     scale per segment of scale_segment_m metres (random-walk prior between
//     segments; metric mode: also a prior around 1);
//   - fisheye_from_marker X (components motion_calibration found undetermined
//     get a prior at its value);
//   - every camera's world_from_camera C;
//   - every camera's clock offset o (node clock - robot clock) [s], weak prior;
// with the measurements
//   - marker detections: the 4 corners reprojected through the camera's model
//     (when present), else the 6-DoF pose error whitened by the detection's
//     information; Huber; chi-square rejection between rounds;
//   - blobs in the fisheye: the camera centre (+ blob_offset_in_camera_m)
//     reprojected; Cauchy; look_up's gated, unambiguous nearest-neighbour
//     association re-run at the current estimate each round.
// A time t between nodes k and k+1 has the pose
//   P(t) = Interp(N_k Nref_k^-1, N_k+1 Nref_k+1^-1, alpha) * Fref(t),
// Nref/Fref the initial (input, scaled) trajectory, alpha = (t - t_k) / (t_k+1 - t_k),
// Interp linear in translation and slerp in rotation: the input's shape between
// nodes is kept and only its correction is interpolated. For detections
// t = t_camera - o; Fref(t) is expanded to first order around the previous
// round's t (body velocity), so the offset is differentiable.
//
// Gauge: the first node is held at the input's first pose (scaled): the
// registration's world is the trajectory's first pose, as for the paper's
// stages (doc/conventions.md).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <type_traits>
#include <variant>

#include "blob_association.h"
#include "fill_reducing_ordering.h"
#include "joint_costs.h"
#include "lookboth/calib/stages.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/core/threads.h"
#include "pose_costs.h"
#include "sparse_covariance.h"

namespace lookboth {
namespace {

using calib_detail::FillOrdering;
using calib_detail::FillOrderingMethod;
using calib_detail::fillOrderingMethodName;
using calib_detail::newPoseManifold;
using calib_detail::paramsToPose;
using calib_detail::parseFillOrderingMethod;
using calib_detail::poseError;
using calib_detail::poseFromParams;
using calib_detail::poseToParams;
using calib_detail::solverOrdering;
using calib_detail::SparseCovariance;
using calib_detail::sqrtInformation;
using namespace joint_detail;

constexpr double kDeg = M_PI / 180.0;
constexpr TimeNs kMaxGapNs = 500'000'000;     // trajectory gaps longer than this are not crossed
constexpr double kDriftModelTolerance = 0.1;  // a drift sigma factor changed by more: another round
constexpr TimeNs kSmoothingGapNs = 100'000'000;  // samples farther apart: not smoothed across
constexpr double kRebracketS = 0.005;            // clock offsets moved less: no new round (below)
// A clock offset estimated this far [ms] from the configured one, and
// beyond 3 sigma, is reported: a sixth of a 30 Hz frame period.
constexpr double kMinClockChangeMs = 5.0;
// A fisheye_from_marker component neither determined nor held by a prior is
// a warning when its sigma exceeds this many times max_*_sigma (1 cm and
// 2.5 deg by default); below, a note.
constexpr double kLooseFactor = 5.0;

struct Detection {
  std::size_t association = 0;
  std::size_t camera = 0;  // index into the joint's cameras
  bool corners = false;
  bool inlier = true;
  bool in_range = true;
  Matrix6d sqrt_info = Matrix6d::Identity();
  TimeNs t_camera = 0;
};

struct JointCamera {
  CameraRegistration* registration = nullptr;
  const Camera* model = nullptr;  // env camera calibration (corners), may be null
  double pose[7];
  Rigid3d start;         // the pose the joint started from (look_up's, or the restart's)
  double offset_s = 0;   // node - robot [s]
  double offset0_s = 0;  // configured (associate) [s]
  std::vector<std::size_t> detections;
  int blobs = 0;
};

Matrix6d detectionSqrtInfo(const MarkerObservation& m, double dt, double dr) {
  if (m.information.isZero(0)) {
    Matrix6d info = Matrix6d::Zero();
    info.topLeftCorner<3, 3>().diagonal().setConstant(1.0 / (dt * dt));
    info.bottomRightCorner<3, 3>().diagonal().setConstant(1.0 / (dr * dr));
    return sqrtInformation(info);
  }
  return sqrtInformation(m.information);
}

const char* kComponentNames[6] = {
    "x", "y", "z", "roll (about x)", "pitch (about y)", "yaw (about z)"};

// The clock searches' pieces. A blob frame and world_from_fisheye there.
using BlobView = std::pair<const BlobObservation*, Rigid3d>;

// The frames with blobs from `first` - 3 s to `last` + 3 s (robot clock), at
// most 300 evenly spread, with their pose from `pose_at` (none: left out).
template <typename PoseAt>
std::vector<BlobView> blobViews(const std::vector<BlobObservation>& blobs, TimeNs first,
                                TimeNs last, const PoseAt& pose_at) {
  const TimeNs margin = 3'000'000'000;
  std::vector<const BlobObservation*> near;
  for (const BlobObservation& b : blobs) {
    if (!b.blobs.empty() && b.t >= first - margin && b.t <= last + margin) near.push_back(&b);
  }
  std::vector<BlobView> views;
  const std::size_t step = std::max<std::size_t>(1, near.size() / 300);
  for (std::size_t i = 0; i < near.size(); i += step) {
    if (const auto w = pose_at(near[i]->t)) views.emplace_back(near[i], *w);
  }
  return views;
}

// Over the views that see p_in_world, the mean distance from its projection
// to the nearest blob, truncated at `truncate_px`; NaN when fewer than 10 do.
double nearestBlobScore(const Camera& fisheye, const std::vector<BlobView>& views,
                        const Eigen::Vector3d& p_in_world, double truncate_px) {
  double sum = 0;
  int seen = 0;
  for (const auto& [frame, world_from_fisheye] : views) {
    const Eigen::Vector3d p = world_from_fisheye.inverse() * p_in_world;
    if (p.z() <= 0) continue;
    const auto pixel = fisheye.project(p);
    if (!pixel || !fisheye.isInImage(*pixel)) continue;
    double d = truncate_px;
    for (const Blob& b : frame->blobs) d = std::min(d, (Eigen::Vector2d(b.u, b.v) - *pixel).norm());
    sum += d;
    ++seen;
  }
  return seen < 10 ? std::numeric_limits<double>::quiet_NaN() : sum / seen;
}

// Component-wise median of the poses' positions (not empty).
Eigen::Vector3d medianPosition(const std::vector<Rigid3d>& poses) {
  Eigen::Vector3d median;
  for (int i = 0; i < 3; ++i) {
    std::vector<double> v;
    for (const Rigid3d& r : poses) v.push_back(r.translation[i]);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    median[i] = v[v.size() / 2];
  }
  return median;
}

// Per-detection camera poses world_from_marker * camera_from_marker^-1 made
// to share one rotation, their mean: a detection's own rotation is the
// marker's, whose noise (degrees with a small marker) moves the camera's
// position by metres at 3 m, while its position in the camera is good to
// centimetres. Then a candidate's position is where the marker was in the
// world minus the shared rotation times where the camera saw it, and their
// spread measures how well the trial clock offset puts the marker on a
// rigid path under the camera. `marker_in_camera[i]` goes with candidate i.
void shareMeanRotation(std::vector<Rigid3d>& candidates,
                       const std::vector<Eigen::Vector3d>& marker_in_camera) {
  if (candidates.empty()) return;
  std::vector<Eigen::Quaterniond> rotations;
  for (const Rigid3d& r : candidates) rotations.push_back(r.rotation);
  const Eigen::Quaterniond mean = calib_detail::meanRotation(rotations);
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    const Eigen::Vector3d p_marker =
        candidates[i].translation + candidates[i].rotation * marker_in_camera[i];
    candidates[i] = Rigid3d(mean, p_marker - mean * marker_in_camera[i]);
  }
}

// The median distance of the poses' positions from `centre` (infinity: none).
double medianDistance(const std::vector<Rigid3d>& poses, const Eigen::Vector3d& centre) {
  std::vector<double> d;
  for (const Rigid3d& r : poses) d.push_back((r.translation - centre).norm());
  if (d.empty()) return std::numeric_limits<double>::infinity();
  std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
  return d[d.size() / 2];
}

}  // namespace

void runJoint(RegistrationProblem& problem, const JointOptions& options,
              const ProgressReporter& progress) {
  // LOOKBOTH_JOINT_VERBOSE=1: diagnostics on stderr; =2: Ceres' full report of every round.
  const char* verbose_env = std::getenv("LOOKBOTH_JOINT_VERBOSE");
  const bool verbose = verbose_env != nullptr;
  const bool verbose_every_round = verbose && verbose_env[0] == '2';
  // ---- what the earlier stages must have produced ----
  if (!problem.associated) {
    throw Error("joint needs associated detections: put 'associate' before it");
  }
  if (!problem.fisheye_from_marker) {
    throw Error(
        "joint needs fisheye_from_marker and the scale: put 'motion_calibration' before it");
  }
  bool any_pose = false;
  for (const CameraRegistration& c : problem.result.cameras) {
    if (c.stage_poses.count("look_down")) any_pose = true;
  }
  if (!any_pose && !problem.result.cameras.empty()) {
    throw Error("joint needs initial camera poses: put 'look_down' before it");
  }
  const RegistrationInput& input = problem.input;
  Registration& result = problem.result;
  const bool visual = input.mode == TrajectoryMode::kVisual;
  const double scale0 = problem.scale;
  // Visual mode: the input trajectory, its positions smoothed when they
  // scatter about a smooth motion by more than smooth_input_min_rms_m (a
  // visual odometry's frame-to-frame jitter). A smooth input is used as given,
  // so that nothing biases an exact one, and so is a metric one (wheel
  // odometry integrates; a fast robot's true jerk would pass for jitter).
  double input_scatter_m = 0;  // [m]
  std::vector<StampedPose> smoothed;
  if (visual && options.smooth_input_s > 0) {
    smoothed = smoothPositions(input.trajectory.samples(), options.smooth_input_s, kSmoothingGapNs,
                               &input_scatter_m);
    input_scatter_m *= scale0;  // the input's units to metres
  }
  const bool smooth_input = !smoothed.empty() && input_scatter_m > options.smooth_input_min_rms_m;
  const Trajectory reference_trajectory =
      smooth_input ? Trajectory(std::move(smoothed)) : input.trajectory;
  if (smooth_input) {
    result.observability.message +=
        (result.observability.message.empty() ? "" : " ") +
        std::string("joint: the input trajectory's positions scatter ") +
        formatFixed(input_scatter_m * 1e3, 2) + " mm RMS about local quadratic fits over +-" +
        formatFixed(options.smooth_input_s, 2) + " s; they were smoothed (smooth_input_s).";
  }
  if (verbose) {
    std::cerr << "joint: input positions scatter " << input_scatter_m * 1e3
              << " mm RMS about local quadratic fits over +-" << options.smooth_input_s << " s"
              << (smooth_input ? ": smoothed" : ": used as given") << "\n";
  }
  const std::vector<StampedPose>& samples = reference_trajectory.samples();
  if (samples.size() < 2) throw Error("joint: the trajectory has fewer than 2 samples");

  // ---- fisheye_from_marker ----
  Rigid3d X0 = *problem.fisheye_from_marker;
  if (options.fisheye_from_marker_from_ground_truth) {
    if (!input.manifest.ground_truth.fisheye_from_marker) {
      throw Error(
          "joint: fisheye_from_marker_from_ground_truth is set but the dataset has no ground-truth "
          "fisheye_from_marker");
    }
    X0 = *input.manifest.ground_truth.fisheye_from_marker;
  }
  double x_params[7];
  poseToParams(X0, x_params);

  // ---- trajectory nodes ----
  const TimeNs interval = static_cast<TimeNs>(options.node_interval_s * 1e9);
  std::vector<std::size_t> node_sample;  // sample index of each node
  node_sample.push_back(0);
  for (std::size_t i = 1; i + 1 < samples.size(); ++i) {
    if (samples[i].t - samples[node_sample.back()].t >= interval) node_sample.push_back(i);
  }
  node_sample.push_back(samples.size() - 1);
  const std::size_t n_nodes = node_sample.size();
  std::vector<TimeNs> node_t(n_nodes);
  std::vector<Rigid3d> node_ref(n_nodes);  // Nref (scaled input)
  std::vector<std::array<double, 7>> nodes(n_nodes);
  for (std::size_t k = 0; k < n_nodes; ++k) {
    node_t[k] = samples[node_sample[k]].t;
    node_ref[k] = problem.metricWorldFromFisheye(samples[node_sample[k]].world_from_body);
    poseToParams(node_ref[k], nodes[k].data());
  }
  // Scale segments by metric distance along the trajectory.
  std::vector<std::size_t> segment_of_edge(n_nodes - 1);
  double travelled = 0;
  std::vector<double> edge_length(n_nodes - 1);
  for (std::size_t k = 0; k + 1 < n_nodes; ++k) {
    edge_length[k] = (node_ref[k + 1].translation - node_ref[k].translation).norm();
    segment_of_edge[k] = static_cast<std::size_t>(travelled / options.scale_segment_m);
    travelled += edge_length[k];
  }
  const std::size_t n_segments = segment_of_edge.empty() ? 1 : segment_of_edge.back() + 1;
  std::vector<double> scales(n_segments, visual ? scale0 : 1.0);

  auto refAt = [&](TimeNs t) -> std::optional<Rigid3d> {
    const InterpolationResult r = reference_trajectory.interpolate(t, kMaxGapNs);
    if (!r.ok()) return std::nullopt;
    return problem.metricWorldFromFisheye(r.world_from_body);
  };
  // Bracket of time t (robot clock); nullopt outside the nodes or in a gap.
  auto bracketAt = [&](TimeNs t, bool with_velocity) -> std::optional<Bracket> {
    if (t < node_t.front() || t > node_t.back()) return std::nullopt;
    std::size_t k = static_cast<std::size_t>(std::upper_bound(node_t.begin(), node_t.end(), t) -
                                             node_t.begin());
    k = k == 0 ? 0 : k - 1;
    if (k + 1 >= n_nodes) k = n_nodes - 2;
    const auto reference = refAt(t);
    if (!reference) return std::nullopt;
    Bracket b;
    b.k = k;
    b.duration_s = nsToSeconds(node_t[k + 1] - node_t[k]);
    b.tau_ref_s = nsToSeconds(t - node_t[k]);
    b.ref_inverse_k = node_ref[k].inverse();
    b.ref_inverse_k1 = node_ref[k + 1].inverse();
    b.reference = *reference;
    if (with_velocity) {
      const TimeNs h = 5'000'000;  // 5 ms
      const TimeNs lo = std::max(t - h, node_t.front()), hi = std::min(t + h, node_t.back());
      const auto a = refAt(lo), c = refAt(hi);
      if (a && c && hi > lo) {
        const double dt = nsToSeconds(hi - lo);
        b.velocity_world = (c->translation - a->translation) / dt;
        b.omega_body =
            so3Log(Eigen::Quaterniond(reference->rotation.conjugate() * c->rotation)) / dt -
            so3Log(Eigen::Quaterniond(reference->rotation.conjugate() * a->rotation)) / dt;
      }
    }
    return b;
  };

  // ---- cameras ----
  std::map<std::string, const Camera*> env_models;
  for (const CameraSensor& s : input.manifest.cameras) {
    if (s.role == SensorRole::kEnvCamera && s.camera) env_models[s.label] = &*s.camera;
  }
  std::map<std::string, TimeNs> configured_offsets;
  for (const Association& a : problem.associations) {
    configured_offsets[problem.marker(a).camera] = problem.marker(a).t - a.t_robot;
  }
  // The fisheye model when the blobs can be used (the offset search below).
  const Camera* blob_fisheye = nullptr;
  if (options.use_blobs && !input.blobs.empty()) {
    const CameraSensor* f = input.manifest.fisheye();
    if (f && f->camera) blob_fisheye = &*f->camera;
  }
  std::vector<JointCamera> cameras;
  // Unregistered by look_down, given another chance here: label -> offset
  // found by the search below, relative to the configured one [s].
  std::map<std::string, double> restarted;
  for (CameraRegistration& c : result.cameras) {
    Rigid3d start = c.world_from_camera;
    if (c.status != CameraStatus::kRegistered) {
      // Detections that disagree (e.g. a clock off by 100s of ms: look_down
      // found the camera suspect or could not register it) may agree once the
      // offset is estimated: start from the offset that makes them agree best
      // and the median of the per-detection poses world_from_marker *
      // camera_from_marker^-1.
      const auto found = problem.associations_by_camera.find(c.label);
      if (found == problem.associations_by_camera.end() ||
          static_cast<int>(found->second.size()) < options.min_detections) {
        continue;
      }
      // The per-detection poses at a trial clock offset [s] (relative to the
      // configured one), their median position and spread.
      auto trial = [&](double shift_s, std::vector<Rigid3d>& candidates, Eigen::Vector3d& median) {
        candidates.clear();
        std::vector<Eigen::Vector3d> marker_in_camera;
        for (std::size_t a : found->second) {
          const Association& as = problem.associations[a];
          const auto w = refAt(as.t_robot - static_cast<TimeNs>(std::llround(shift_s * 1e9)));
          if (!w) continue;
          candidates.push_back(*w * X0 * problem.marker(as).camera_from_marker.inverse());
          marker_in_camera.push_back(problem.marker(as).camera_from_marker.translation);
        }
        if (static_cast<int>(candidates.size()) < options.min_detections) return 1e300;
        shareMeanRotation(candidates, marker_in_camera);
        median = medianPosition(candidates);
        return medianDistance(candidates, median);
      };
      // The fisheye's view of a trial position: over the blob frames around
      // the camera's detections, the mean distance from its projection to
      // the nearest blob, truncated [px]; NaN with too few frames seeing it.
      // (A pass in one direction moves every per-detection pose alike when the
      // clock shifts: their spread cannot tell the offset, the blobs can.)
      TimeNs t_first = std::numeric_limits<TimeNs>::max(), t_last = 0;
      for (std::size_t a : found->second) {
        t_first = std::min(t_first, problem.associations[a].t_robot);
        t_last = std::max(t_last, problem.associations[a].t_robot);
      }
      std::vector<BlobView> views;
      if (blob_fisheye != nullptr) views = blobViews(input.blobs, t_first, t_last, refAt);
      auto blobScore = [&](const Eigen::Vector3d& p_in_world) -> double {
        if (blob_fisheye == nullptr) return std::numeric_limits<double>::quiet_NaN();
        return nearestBlobScore(*blob_fisheye, views, p_in_world, 30.0);
      };
      // With estimated clocks: the offset within +-0.5 s (10 ms steps) that
      // makes the detections agree among themselves (their spread within
      // 1.5x or 2 cm of the least) and, of those, the fisheye's blobs agree
      // best with the camera they put there; without blobs the least spread.
      double best_shift = 0;
      std::vector<Rigid3d> candidates;
      Eigen::Vector3d median;
      double best = trial(0.0, candidates, median);
      if (options.estimate_clock_offsets) {
        std::vector<double> shifts, spreads, blob_scores;
        for (int k = -50; k <= 50; ++k) {
          const double spread = trial(0.01 * k, candidates, median);
          if (spread >= 1e300) continue;
          shifts.push_back(0.01 * k);
          spreads.push_back(spread);
          blob_scores.push_back(blobScore(median));
        }
        if (!shifts.empty()) {
          const double least = *std::min_element(spreads.begin(), spreads.end());
          const double admissible = std::max(1.5 * least, least + 0.02);
          // Whether shift i beats shift j: by the blobs when both have a
          // score (by more than `margin_px` or `ratio` of j's), else by the
          // spread (`factor` times smaller); `by_score`: a score beats none.
          auto beats = [&](std::size_t i, std::size_t j, double margin_px, double ratio,
                           double factor, bool by_score) {
            const bool si = !std::isnan(blob_scores[i]), sj = !std::isnan(blob_scores[j]);
            if (si && sj) {
              return blob_scores[i] < blob_scores[j] - std::max(margin_px, ratio * blob_scores[j]);
            }
            if (by_score && si != sj) return si;
            return factor * spreads[i] < spreads[j];
          };
          std::size_t chosen = shifts.size();
          for (std::size_t i = 0; i < shifts.size(); ++i) {
            if (spreads[i] > admissible) continue;
            if (chosen == shifts.size() || beats(i, chosen, 0.0, 0.0, 1.0, true)) chosen = i;
          }
          // The configured offset stays unless the chosen one is clearly
          // better: by the blobs, 1 px or 10 % of its score, else by the
          // spread, 1.5x (the scores are noisy and flat along one pass).
          const auto zero = std::find(shifts.begin(), shifts.end(), 0.0);
          if (zero != shifts.end()) {
            const std::size_t z = static_cast<std::size_t>(zero - shifts.begin());
            if (!beats(chosen, z, 1.0, 0.1, 1.5, false)) chosen = z;
          }
          best = spreads[chosen];
          best_shift = shifts[chosen];
          if (verbose) {
            std::cerr << "joint clock search " << c.label << ": chose " << best_shift * 1e3
                      << " ms (spread admissible below " << admissible << " m)\n";
            for (std::size_t i = 0; i < shifts.size(); i += 5) {
              std::cerr << "  " << shifts[i] * 1e3 << " ms: spread " << spreads[i] << " m, blobs "
                        << blob_scores[i] << " px\n";
            }
          }
        }
      }
      if (best >= 1e300) continue;
      trial(best_shift, candidates, median);
      std::vector<Eigen::Quaterniond> rotations;
      for (const Rigid3d& r : candidates) rotations.push_back(r.rotation);
      start = Rigid3d(calib_detail::meanRotation(rotations), median);
      restarted[c.label] = best_shift;
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
    if (const auto r = restarted.find(c.label); r != restarted.end()) jc.offset_s += r->second;
    cameras.push_back(jc);
  }
  const double half_side = 0.5 * input.manifest.marker.size_m;
  const std::array<Eigen::Vector3d, 4> corners_in_marker = {
      Eigen::Vector3d(-half_side, half_side, 0), Eigen::Vector3d(half_side, half_side, 0),
      Eigen::Vector3d(half_side, -half_side, 0), Eigen::Vector3d(-half_side, -half_side, 0)};

  // ---- detections ----
  std::vector<Detection> detections;
  {
    std::map<std::string, std::size_t> index;
    for (std::size_t c = 0; c < cameras.size(); ++c) index[cameras[c].registration->label] = c;
    for (const auto& [label, indices] : problem.associations_by_camera) {
      const auto found = index.find(label);
      if (found == index.end()) continue;
      const auto inliers = problem.inliers_by_camera.find(label);
      for (std::size_t a : indices) {
        const MarkerObservation& m = problem.marker(problem.associations[a]);
        Detection d;
        d.association = a;
        d.camera = found->second;
        d.t_camera = m.t;
        d.corners = options.use_corners && m.corners_px.size() == 4 && m.corner_sigma_px > 0 &&
                    cameras[found->second].model != nullptr &&
                    cameras[found->second].model->params().size() <= kMaxParams;
        d.sqrt_info = detectionSqrtInfo(m, options.default_translation_sigma_m,
                                        options.default_rotation_sigma_deg * kDeg);
        // Round 0 starts from look_down's inliers.
        d.inlier =
            restarted.count(label) > 0 || inliers == problem.inliers_by_camera.end() ||
            std::find(inliers->second.begin(), inliers->second.end(), a) != inliers->second.end();
        cameras[found->second].detections.push_back(detections.size());
        detections.push_back(d);
      }
    }
  }

  // ---- fisheye and blob frames ----
  const CameraSensor* fisheye_sensor = input.manifest.fisheye();
  const Camera* fisheye =
      fisheye_sensor && fisheye_sensor->camera ? &*fisheye_sensor->camera : nullptr;
  const bool use_blobs = options.use_blobs && fisheye && !input.blobs.empty() &&
                         fisheye->params().size() <= kMaxParams;
  if (options.use_blobs && !use_blobs && !input.blobs.empty()) {
    result.warnings.push_back("joint: the fisheye has no usable calibration; blobs not used");
  }
  struct Frame {
    const BlobObservation* blobs;
    Bracket bracket;
  };
  std::vector<Frame> frames;
  if (use_blobs) {
    for (const BlobObservation& b : input.blobs) {
      if (b.blobs.empty()) continue;
      if (const auto bracket = bracketAt(b.t, false)) frames.push_back({&b, *bracket});
    }
  }

  // ---- the undetermined components of fisheye_from_marker ----
  std::array<bool, 6> prior_on = {false, false, false, false, false, false};
  if (!options.fix_fisheye_from_marker) {
    for (int c = 0; c < 6; ++c) prior_on[c] = !result.fisheye_from_marker_determined[c];
  }

  auto evalPose = [&](const Bracket& b, double tau) {
    return poseAt<double>(b, nodes[b.k].data(), nodes[b.k + 1].data(), tau);
  };

  struct BlobMatch {
    std::size_t frame, blob;
  };
  std::vector<std::vector<BlobMatch>> matches(cameras.size());
  auto associateBlobs = [&]() {
    for (auto& m : matches) m.clear();
    if (frames.empty()) return;
    const double max_angle = std::min(fisheye->maxIncidenceAngle(), 85.0 * kDeg);
    std::vector<std::pair<double, std::size_t>> by_x;
    std::vector<Eigen::Vector3d> centre(cameras.size());
    double max_height = 0;
    const Eigen::Vector3d o0 =
        evalPose(frames.front().bracket, frames.front().bracket.tau_ref_s).translation;
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      const Rigid3d pose = paramsToPose(cameras[c].pose);
      centre[c] = pose * options.blob_offset_in_camera_m;
      by_x.emplace_back(centre[c].x(), c);
      max_height = std::max(max_height, std::abs(centre[c].z() - o0.z()));
    }
    std::sort(by_x.begin(), by_x.end());
    const double range = std::max(5.0, (max_height + 1.0) * std::tan(max_angle) + 2.0);
    std::vector<std::pair<std::size_t, Eigen::Vector2d>> projected;
    calib_detail::BlobsByColumn by_column;
    for (std::size_t fi = 0; fi < frames.size();
         fi += static_cast<std::size_t>(options.association_frame_step)) {
      const Frame& f = frames[fi];
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
        const auto pixel = fisheye->project(p);
        if (!pixel || !fisheye->isInImage(*pixel, -options.gate_px)) continue;
        projected.emplace_back(c, *pixel);
      }
      if (projected.empty()) continue;
      by_column.assign(f.blobs->blobs);
      for (const auto& [c, pixel] : projected) {
        if (const auto best = calib_detail::associatedBlob(by_column, c, pixel, options.gate_px,
                                                           options.ambiguity_ratio, projected)) {
          matches[c].push_back({fi, *best});
        }
      }
    }
  };

  // Detection brackets for the current offsets.
  std::vector<std::optional<Bracket>> det_bracket(detections.size());
  auto bracketDetections = [&]() {
    for (std::size_t i = 0; i < detections.size(); ++i) {
      const Detection& d = detections[i];
      const TimeNs t_robot =
          d.t_camera - static_cast<TimeNs>(std::llround(cameras[d.camera].offset_s * 1e9));
      det_bracket[i] = bracketAt(t_robot, true);
      detections[i].in_range = det_bracket[i].has_value();
    }
  };
  // Variance factor of the marker measurements (pose, corners): how much
  // larger their residuals are, in variance, than the detector's covariance
  // says (the trajectory between nodes, a detector that underrates its
  // noise). Estimated from the median chi-square between rounds, never
  // below 1; the costs and the rejection are scaled by it.
  double variance_factor[2] = {1.0, 1.0};
  auto markerCost = [&](std::size_t i) -> ceres::CostFunction* {
    const Detection& d = detections[i];
    const double factor = variance_factor[d.corners ? 1 : 0];
    const Bracket& b = *det_bracket[i];
    const MarkerObservation& m = problem.marker(problem.associations[d.association]);
    const double tau_camera = nsToSeconds(d.t_camera - node_t[b.k]);
    if (d.corners) {
      MarkerCornersCost cost;
      cost.bracket = b;
      cost.tau_camera_s = tau_camera;
      cost.camera_model = cameras[d.camera].model;
      cost.corners_in_marker = corners_in_marker;
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
  };
  auto markerChi2 = [&](std::size_t i) {
    std::unique_ptr<ceres::CostFunction> cost(markerCost(i));
    const Detection& d = detections[i];
    const Bracket& b = *det_bracket[i];
    const double* blocks[5] = {nodes[b.k].data(), nodes[b.k + 1].data(), x_params,
                               cameras[d.camera].pose, &cameras[d.camera].offset_s};
    double r[8];
    if (!cost->Evaluate(blocks, r, nullptr)) return 1e300;
    double sum = 0;
    for (int k = 0; k < cost->num_residuals(); ++k) sum += r[k] * r[k];
    return sum;
  };

  ceres::Solver::Options solver;
  if (options.linear_solver == "sparse_schur") {
    solver.linear_solver_type = ceres::SPARSE_SCHUR;
  } else if (options.linear_solver == "iterative_schur") {
    solver.linear_solver_type = ceres::ITERATIVE_SCHUR;
    solver.preconditioner_type = ceres::SCHUR_JACOBI;
  } else {
    solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  }
  FillOrderingMethod fill_method = FillOrderingMethod::kAuto;
  parseFillOrderingMethod(options.fill_reducing_ordering, &fill_method);  // check()ed
  struct {
    bool made = false;
    double residuals = 0;  // residual blocks of the round it was made on
    FillOrderingMethod method = FillOrderingMethod::kAmd;
  } ordering_choice;  // auto's last choice
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = options.threads;
  solver.function_tolerance = options.function_tolerance;
  solver.gradient_tolerance = 1e-12;
  solver.parameter_tolerance = 1e-9;
  solver.initial_trust_region_radius = options.initial_trust_region_radius;
  solver.minimizer_progress_to_stdout = verbose_every_round;  // =2: every iteration

  std::unique_ptr<ceres::LossFunction> huber, cauchy;
  std::unique_ptr<FramePoseCache> frame_poses;  // the blob frames' poses at each evaluation point
  std::unique_ptr<ceres::Problem> ceres_problem;
  // Process CPU time [s], for the verbose breakdown.
  auto cpu = []() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; };
  double cpu_mark = cpu();
  auto lap = [&]() {
    const double now = cpu(), d = now - cpu_mark;
    cpu_mark = now;
    return d;
  };
  std::vector<char> previous_inlier;
  std::vector<double> previous_offset;
  std::size_t previous_blobs = 0;
  bool previous_converged = true;  // the last round's solve converged (not stopped at its cap)
  // The inliers of the last round were judged on a converged estimate (a
  // short drift round's is not: the round after it judges them again).
  bool inliers_judged_converged = true;
  // The last round was a short drift round (drift_round_max_*, after the
  // first update): its estimate is a step on the way, where good detections
  // can sit several sigmas off, and a detection set aside there stays out (a
  // flexible trajectory follows the detections kept). The round after it
  // keeps the inliers and variance factors as they were; outliers are judged
  // on converged estimates only: after the first round (which runs to
  // convergence) and after the round that follows the last update.
  bool previous_short = false;
  // The clock search of the restarted cameras again after the first round,
  // on the trajectory that round corrected: there a camera put at the right
  // offset projects within a pixel or two of its blob, where on the input
  // trajectory the score was tens of pixels and flat (one pass in one
  // direction trades a clock shift for a tilt of the camera). The offset
  // moves only when another is clearly better (1 px or 20 % of the score).
  // Cameras the search just moved: their pose is a rough start (the median of
  // their detections), so the next rejection keeps all of their detections
  // and leaves them out of the variance factors; the round after judges them.
  std::vector<bool> restarted_now(cameras.size(), false);
  // The drift model estimated from the data (estimate_drift_model): factors
  // on the configured sigmas of the relative motions' horizontal
  // translation, vertical translation, tilt (roll, pitch) and yaw, by
  // Helmert's variance component estimation after a round: each group's
  // factor is multiplied by sqrt(sum of its squared whitened residuals / its
  // redundancy), the redundancy sum_i (1 - (J_i Cov J_i^T)_cc) over the
  // group's residual components (what the other measurements leave to the
  // relative motions to decide), from the covariance of the nodes and scales
  // on the pattern of the problem (selected inversion). Gap edges are left out.
  double drift_factor[4] = {1, 1, 1, 1};
  double last_step[4] = {1, 1, 1, 1};
  bool drift_model_changed = false;   // by the update after this round: another round
  bool drift_still_changing = false;  // the last update made changed the model (> 10 %)
  int drift_updates = 0;              // made (each followed by a round)
  bool drift_model_failed = false;    // its covariance could not be computed
  const int max_rounds =
      options.rounds + (options.estimate_drift_model ? options.drift_model_updates : 0);
  std::vector<ceres::ResidualBlockId> edge_block;  // per edge; null across a gap
  auto updateDriftModel = [&](ceres::Problem& Q) -> bool {
    lap();
    auto isFree = [&](const double* b) {
      return !Q.IsParameterBlockConstant(const_cast<double*>(b));
    };
    std::vector<std::pair<const double*, const double*>> pairs;
    std::set<std::pair<const double*, const double*>> seen;
    auto want = [&](const double* a, const double* b) {
      if (!isFree(a) || !isFree(b)) return;
      if (seen.count({b, a}) == 0 && seen.insert({a, b}).second) pairs.emplace_back(a, b);
    };
    for (std::size_t k = 0; k < edge_block.size(); ++k) {
      if (edge_block[k] == nullptr) continue;
      const double* blocks[3] = {nodes[k].data(), nodes[k + 1].data(), &scales[segment_of_edge[k]]};
      for (int i = 0; i < 3; ++i) {
        for (int j = i; j < 3; ++j) want(blocks[i], blocks[j]);
      }
    }
    // The blocks that touch many others are requested too, so that they go
    // to the dense group: their fill would make the factor 10x larger.
    for (const JointCamera& c : cameras) want(c.pose, c.pose);
    want(x_params, x_params);
    frame_poses->PrepareForEvaluation(true, true);
    SparseCovariance cov;
    if (!cov.compute(pairs, &Q, options.threads)) {
      result.warnings.push_back("joint: the drift model could not be estimated (" + cov.message() +
                                "); the configured one was used, so the reported uncertainty "
                                "may not fit this trajectory's drift");
      drift_model_failed = true;  // no further attempts
      return false;
    }
    double squares[4] = {0, 0, 0, 0}, redundancy[4] = {0, 0, 0, 0};
    constexpr int kGroupOf[6] = {0, 0, 1, 2, 2, 3};  // residual component -> group
    for (std::size_t k = 0; k < edge_block.size(); ++k) {
      if (edge_block[k] == nullptr) continue;
      double* blocks[3] = {nodes[k].data(), nodes[k + 1].data(), &scales[segment_of_edge[k]]};
      Eigen::Matrix<double, 6, 7, Eigen::RowMajor> ambient[2];
      Eigen::Matrix<double, 6, 1> d_scale;
      double* jacobians[3] = {isFree(blocks[0]) ? ambient[0].data() : nullptr,
                              isFree(blocks[1]) ? ambient[1].data() : nullptr,
                              isFree(blocks[2]) ? d_scale.data() : nullptr};
      double r[6];
      if (!Q.GetCostFunctionForResidualBlock(edge_block[k])->Evaluate(blocks, r, jacobians)) {
        continue;
      }
      Eigen::Matrix<double, 6, Eigen::Dynamic> tangent[3];
      for (int i = 0; i < 2; ++i) {
        if (jacobians[i] == nullptr) continue;
        Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus;
        Q.GetManifold(blocks[i])->PlusJacobian(blocks[i], plus.data());
        tangent[i] = ambient[i] * plus;
      }
      if (jacobians[2] != nullptr) tangent[2] = d_scale;
      Eigen::Matrix<double, 6, 6> leverage = Eigen::Matrix<double, 6, 6>::Zero();
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
          if (jacobians[i] == nullptr || jacobians[j] == nullptr) continue;
          leverage += tangent[i] * cov.block(blocks[i], blocks[j]) * tangent[j].transpose();
        }
      }
      const Eigen::Matrix<double, 6, 1> h = leverage.diagonal();
      if (!h.allFinite() || h.maxCoeff() > 1 + 1e-6 || h.minCoeff() < -1e-9) continue;
      for (int c = 0; c < 6; ++c) {
        squares[kGroupOf[c]] += r[c] * r[c];
        redundancy[kGroupOf[c]] += 1 - h[c];
      }
    }
    bool changed = false;
    for (int g = 0; g < 4; ++g) {
      if (redundancy[g] < 10) continue;  // the data leave this group nothing to judge by
      const double step = std::sqrt(std::clamp(squares[g] / redundancy[g], 1e-4, 1e4));
      // A group moved the same way twice: its step squared. Helmert's
      // iteration converges linearly, slowly for a component the odometry
      // does not have (its factor tends to 0): on `paper_det` 4 updates reach
      // what the odometry's own model gives, where plain steps need 6.
      const bool again = drift_updates > 0 && (step - 1) * (last_step[g] - 1) > 0;
      const double applied = again ? step * step : step;
      last_step[g] = step;
      drift_factor[g] = std::clamp(drift_factor[g] * applied, 1e-3, 1e3);
      changed |= std::abs(step - 1) > kDriftModelTolerance;
    }
    if (verbose) {
      std::cerr << "joint drift model update " << drift_updates + 1 << " (CPU " << lap() << " s"
                << cov.describe() << "): sigma factors horizontal " << drift_factor[0]
                << ", vertical " << drift_factor[1] << ", tilt " << drift_factor[2] << ", yaw "
                << drift_factor[3] << " (redundancies " << redundancy[0] << ", " << redundancy[1]
                << ", " << redundancy[2] << ", " << redundancy[3] << ")\n";
    }
    return changed;
  };
  auto researchRestartedClocks = [&]() {
    auto poseNow = [&](TimeNs t) -> std::optional<Rigid3d> {
      const auto b = bracketAt(t, false);
      if (!b) return std::nullopt;
      return poseAt<double>(*b, nodes[b->k].data(), nodes[b->k + 1].data(), b->tau_ref_s);
    };
    const Rigid3d X = paramsToPose(x_params);
    for (JointCamera& jc : cameras) {
      const std::string& label = jc.registration->label;
      if (restarted.count(label) == 0) continue;
      const auto found = problem.associations_by_camera.find(label);
      if (found == problem.associations_by_camera.end()) continue;
      TimeNs t_first = std::numeric_limits<TimeNs>::max(), t_last = 0;
      for (std::size_t a : found->second) {
        t_first = std::min(t_first, problem.marker(problem.associations[a]).t);
        t_last = std::max(t_last, problem.marker(problem.associations[a]).t);
      }
      const TimeNs shift_now = static_cast<TimeNs>(std::llround(jc.offset_s * 1e9));
      const std::vector<BlobView> views =
          blobViews(input.blobs, t_first - shift_now, t_last - shift_now, poseNow);
      // At an offset [s]: the per-detection camera poses, their median
      // position, and the mean distance from its projection to the nearest
      // blob, truncated at 10 px (NaN: too few views).
      auto score = [&](double offset_s, std::vector<Rigid3d>& candidates, Eigen::Vector3d& median) {
        candidates.clear();
        std::vector<Eigen::Vector3d> marker_in_camera;
        for (std::size_t a : found->second) {
          const MarkerObservation& m = problem.marker(problem.associations[a]);
          const auto w = poseNow(m.t - static_cast<TimeNs>(std::llround(offset_s * 1e9)));
          if (!w) continue;
          candidates.push_back(*w * X * m.camera_from_marker.inverse());
          marker_in_camera.push_back(m.camera_from_marker.translation);
        }
        if (static_cast<int>(candidates.size()) < options.min_detections) {
          return std::numeric_limits<double>::quiet_NaN();
        }
        shareMeanRotation(candidates, marker_in_camera);
        median = medianPosition(candidates);
        return nearestBlobScore(*blob_fisheye, views, median, 10.0);
      };
      std::vector<Rigid3d> candidates;
      Eigen::Vector3d median;
      // The detections must agree among themselves at the current offset
      // (their median distance from their median below 10 cm: else they do
      // not say where the camera is) and as well at the new one.
      constexpr double kMaxSpread = 0.1;
      auto spread = [&](double offset_s) {
        score(offset_s, candidates, median);
        return medianDistance(candidates, median);
      };
      const double now = score(jc.offset_s, candidates, median);
      double best = now, best_offset = jc.offset_s;
      for (int k = -50; k <= 50; ++k) {
        const double offset = jc.offset_s + 0.01 * k;
        const double v = score(offset, candidates, median);
        if (!std::isnan(v) && (std::isnan(best) || v < best)) {
          best = v;
          best_offset = offset;
        }
      }
      const double spread_now = spread(jc.offset_s), spread_best = spread(best_offset);
      const bool move = !std::isnan(best) && best_offset != jc.offset_s &&
                        (std::isnan(now) || best < now - std::max(1.0, 0.2 * now)) &&
                        spread_now < kMaxSpread && spread_best <= 1.2 * spread_now + 0.005;
      if (verbose) {
        std::cerr << "joint clock search after round 1 " << label << ": offset "
                  << jc.offset_s * 1e3 << " ms scores " << now << " px (spread " << spread_now
                  << " m); best " << best_offset * 1e3 << " ms " << best << " px (spread "
                  << spread_best << " m)" << (move ? " (moved)" : "") << "\n";
      }
      if (!move) continue;
      score(best_offset, candidates, median);
      std::vector<Eigen::Quaterniond> rotations;
      for (const Rigid3d& r : candidates) rotations.push_back(r.rotation);
      poseToParams(Rigid3d(calib_detail::meanRotation(rotations), median), jc.pose);
      jc.offset_s = best_offset;
      restarted_now[static_cast<std::size_t>(&jc - cameras.data())] = true;
    }
  };
  for (int round = 0; round < max_rounds; ++round) {
    // Rounds past `rounds` run only for a drift model that changed.
    if (round >= options.rounds && !drift_model_changed && previous_converged &&
        inliers_judged_converged) {
      break;
    }
    inliers_judged_converged = previous_converged;
    // A round whose solution serves only the next drift model update (another
    // follows: the model is still changing) moves the estimate towards the
    // weights of that update; the update re-weights it, and the round after
    // the last update converges: such a round uses fewer blobs
    // (drift_round_max_blobs_per_camera) and, after the first update, stops
    // after drift_round_max_iterations steps (previous_short).
    const bool drift_update_follows =
        options.estimate_drift_model && !options.fix_trajectory && !drift_model_failed &&
        drift_updates < options.drift_model_updates &&
        (drift_updates == 0 || drift_still_changing) && round + 1 < max_rounds;
    progress.checkStop();
    progress.report("joint", round, max_rounds, "round " + std::to_string(round + 1));
    if (round == 1 && blob_fisheye != nullptr && options.estimate_clock_offsets) {
      researchRestartedClocks();
    }
    bracketDetections();
    if (round > 0 && !previous_short) {
      // Outliers at the current estimate (every detection is reconsidered),
      // after the variance factors are re-estimated from the medians.
      std::vector<double> chi2(detections.size(), 0.0);
      std::vector<double> by_kind[2];
      for (std::size_t i = 0; i < detections.size(); ++i) {
        if (!detections[i].in_range) continue;
        const int kind = detections[i].corners ? 1 : 0;
        chi2[i] = markerChi2(i) * variance_factor[kind];  // as with factor 1
        if (!restarted_now[detections[i].camera]) by_kind[kind].push_back(chi2[i]);
      }
      // Medians of the chi-square distribution with 6 and 8 degrees of freedom.
      const double expected_median[2] = {5.3481, 7.3441};
      for (int kind = 0; kind < 2; ++kind) {
        std::vector<double>& v = by_kind[kind];
        if (v.size() < 10 || !options.estimate_variance_factor) continue;
        std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
        variance_factor[kind] = std::max(1.0, v[v.size() / 2] / expected_median[kind]);
      }
      for (std::size_t i = 0; i < detections.size(); ++i) {
        if (!detections[i].in_range) continue;
        const int kind = detections[i].corners ? 1 : 0;
        const double bound = kind ? options.reject_chi2_corners : options.reject_chi2_pose;
        detections[i].inlier =
            restarted_now[detections[i].camera] || chi2[i] / variance_factor[kind] <= bound;
      }
      std::fill(restarted_now.begin(), restarted_now.end(), false);
      if (verbose) {
        std::cerr << "joint round " << round + 1 << ": variance factors pose " << variance_factor[0]
                  << ", corners " << variance_factor[1] << "\n";
      }
    }
    associateBlobs();
    // Another round only when its inputs changed: inliers, blob associations
    // (by more than 0.5 %), or a clock offset by more than 5 ms. Within that a
    // detection's pose is the first-order expansion around the offset it was
    // bracketed at, from the velocity over the same +-5 ms: its error is
    // a dt^2 / 2, 0.025 mm at 2 m/s^2, so re-bracketing would change nothing.
    std::vector<char> inlier(detections.size());
    for (std::size_t i = 0; i < detections.size(); ++i) {
      inlier[i] = detections[i].in_range && detections[i].inlier;
    }
    std::vector<double> offsets;
    for (const JointCamera& c : cameras) offsets.push_back(c.offset_s);
    std::size_t blobs_total = 0;
    for (const auto& m : matches) blobs_total += m.size();
    if (round > 0 && inlier == previous_inlier &&
        std::abs(static_cast<double>(blobs_total) - static_cast<double>(previous_blobs)) <=
            0.005 * static_cast<double>(previous_blobs)) {
      double moved = 0;
      for (std::size_t c = 0; c < cameras.size(); ++c) {
        moved = std::max(moved, std::abs(offsets[c] - previous_offset[c]));
      }
      if (moved < kRebracketS && previous_converged && !drift_model_changed) break;
    }
    previous_inlier = inlier;
    previous_offset = offsets;
    previous_blobs = blobs_total;

    // The losses are shared by many blocks: the problem does not own them
    // (they outlive it: declared before it, reset after it).
    ceres_problem.reset();
    huber = std::make_unique<ceres::HuberLoss>(options.huber);
    cauchy = std::make_unique<ceres::CauchyLoss>(options.cauchy);
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    frame_poses = std::make_unique<FramePoseCache>();
    problem_options.evaluation_callback = frame_poses.get();
    std::vector<std::size_t> frame_slot(frames.size(), SIZE_MAX);
    ceres_problem = std::make_unique<ceres::Problem>(problem_options);
    ceres::Problem& Q = *ceres_problem;
    // Verbose diagnostics: the cost of the odometry, marker and blob residuals apart.
    std::array<std::vector<ceres::ResidualBlockId>, 3> group_blocks;
    std::vector<bool> node_used(n_nodes, false);
    auto addNode = [&](std::size_t k) {
      if (node_used[k]) return;
      node_used[k] = true;
      Q.AddParameterBlock(nodes[k].data(), 7, newPoseManifold());
    };

    // Trajectory: relative motions and scales.
    edge_block.assign(n_nodes > 0 ? n_nodes - 1 : 0, nullptr);
    if (!options.fix_trajectory) {
      for (std::size_t k = 0; k + 1 < n_nodes; ++k) {
        addNode(k);
        addNode(k + 1);
        auto* cost = new RelativeMotionCost;
        const Rigid3d& a = samples[node_sample[k]].world_from_body;
        const Rigid3d& b = samples[node_sample[k + 1]].world_from_body;
        cost->delta_unscaled = a.inverse() * b;
        double d = edge_length[k];
        const bool gap = node_t[k + 1] - node_t[k] > kMaxGapNs;
        cost->sigma_t = std::sqrt(options.min_sigma_m * options.min_sigma_m +
                                  options.drift_m_per_sqrt_m * options.drift_m_per_sqrt_m * d);
        cost->sigma_r = std::sqrt(std::pow(options.min_sigma_deg * kDeg, 2) +
                                  std::pow(options.drift_deg_per_sqrt_m * kDeg, 2) * d);
        if (gap) {  // across a gap the input says little
          cost->sigma_t *= 100;
          cost->sigma_r *= 100;
        }
        cost->vertical_ratio = options.drift_vertical_ratio * drift_factor[1] / drift_factor[0];
        cost->tilt_ratio = options.drift_tilt_ratio * drift_factor[2] / drift_factor[3];
        cost->sigma_t *= drift_factor[0];
        cost->sigma_r *= drift_factor[3];
        const ceres::ResidualBlockId id = Q.AddResidualBlock(
            new ceres::AutoDiffCostFunction<RelativeMotionCost, 6, 7, 7, 1>(cost), nullptr,
            nodes[k].data(), nodes[k + 1].data(), &scales[segment_of_edge[k]]);
        if (!gap) edge_block[k] = id;
        if (verbose) group_blocks[0].push_back(id);
      }
      for (std::size_t j = 0; j < n_segments; ++j) {
        if (j > 0) {
          auto* cost = new ScaleWalkCost;
          cost->sigma = options.scale_walk_sigma * (visual ? scale0 : 1.0);
          Q.AddResidualBlock(new ceres::AutoDiffCostFunction<ScaleWalkCost, 1, 1, 1>(cost), nullptr,
                             &scales[j - 1], &scales[j]);
        }
        if (!visual) {
          auto* cost = new ScalarPriorCost;
          cost->value = 1.0;
          cost->sigma = options.metric_scale_sigma;
          Q.AddResidualBlock(new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, 1>(cost), nullptr,
                             &scales[j]);
        }
      }
    }
    // X and its priors.
    Q.AddParameterBlock(x_params, 7, newPoseManifold());
    for (int c = 0; c < 6; ++c) {
      if (!prior_on[c]) continue;
      auto* cost = new ComponentPriorCost;
      cost->prior = *problem.fisheye_from_marker;
      cost->component = c;
      cost->sigma =
          c < 3 ? options.prior_translation_sigma_m : options.prior_rotation_sigma_deg * kDeg;
      Q.AddResidualBlock(new ceres::AutoDiffCostFunction<ComponentPriorCost, 1, 7>(cost), nullptr,
                         x_params);
    }
    // Cameras, offsets, detections.
    for (JointCamera& c : cameras) {
      Q.AddParameterBlock(c.pose, 7, newPoseManifold());
      Q.AddParameterBlock(&c.offset_s, 1);
      auto* cost = new ScalarPriorCost;
      cost->value = c.offset0_s;
      cost->sigma = options.clock_prior_sigma_s;
      Q.AddResidualBlock(new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, 1>(cost), nullptr,
                         &c.offset_s);
      if (!options.estimate_clock_offsets) Q.SetParameterBlockConstant(&c.offset_s);
    }
    for (std::size_t i = 0; i < detections.size(); ++i) {
      const Detection& d = detections[i];
      if (!d.in_range || !d.inlier) continue;
      const Bracket& b = *det_bracket[i];
      addNode(b.k);
      addNode(b.k + 1);
      const ceres::ResidualBlockId id =
          Q.AddResidualBlock(markerCost(i), huber.get(), nodes[b.k].data(), nodes[b.k + 1].data(),
                             x_params, cameras[d.camera].pose, &cameras[d.camera].offset_s);
      if (verbose) group_blocks[1].push_back(id);
    }
    // Blobs.
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      const std::size_t n = matches[c].size();
      cameras[c].blobs = static_cast<int>(n);
      if (static_cast<int>(n) < options.min_blobs) continue;
      std::size_t keep = options.max_blobs_per_camera > 0
                             ? std::min(n, static_cast<std::size_t>(options.max_blobs_per_camera))
                             : n;
      if (drift_update_follows && options.drift_round_max_blobs_per_camera > 0) {
        keep = std::min(keep, static_cast<std::size_t>(options.drift_round_max_blobs_per_camera));
      }
      for (std::size_t q = 0; q < keep; ++q) {
        const BlobMatch& m = matches[c][q * n / keep];
        const Frame& f = frames[m.frame];
        double* nk = nodes[f.bracket.k].data();
        double* nk1 = nodes[f.bracket.k + 1].data();
        if (frame_slot[m.frame] == SIZE_MAX) {
          frame_slot[m.frame] = frame_poses->add(f.bracket, nk, nk1);
        }
        auto* cost = new CachedBlobCost(
            frame_poses.get(), frame_slot[m.frame], fisheye, options.blob_offset_in_camera_m,
            Eigen::Vector2d(f.blobs->blobs[m.blob].u, f.blobs->blobs[m.blob].v),
            options.blob_sigma_px);
        addNode(f.bracket.k);
        addNode(f.bracket.k + 1);
        const ceres::ResidualBlockId id =
            Q.AddResidualBlock(cost, cauchy.get(), nk, nk1, cameras[c].pose);
        if (verbose) group_blocks[2].push_back(id);
      }
    }
    // Gauge and fixed parts.
    addNode(0);
    Q.SetParameterBlockConstant(nodes[0].data());
    if (options.fix_trajectory) {
      for (std::size_t k = 0; k < n_nodes; ++k) {
        if (node_used[k]) Q.SetParameterBlockConstant(nodes[k].data());
      }
    }
    if (options.fix_fisheye_from_marker) Q.SetParameterBlockConstant(x_params);

    // The elimination order of J^T J (fill_reducing_ordering.h); null =
    // Ceres' own AMD. With `auto` the choice is made on the first round and
    // again whenever the number of residual blocks changes by more than 5 %
    // (the drift rounds' 60 blobs per camera, then all of them): in between
    // the pattern is the same but for a few rejected detections, and the
    // choice is kept, without the cost of the other ordering.
    std::string ordering_note;
    solver.linear_solver_ordering.reset();
    if (solver.linear_solver_type == ceres::SPARSE_NORMAL_CHOLESKY &&
        fill_method != FillOrderingMethod::kAmd) {
      const double residuals = static_cast<double>(Q.NumResidualBlocks());
      FillOrderingMethod method = fill_method;
      if (fill_method == FillOrderingMethod::kAuto && ordering_choice.made &&
          std::abs(residuals - ordering_choice.residuals) <= 0.05 * ordering_choice.residuals) {
        method = ordering_choice.method;
      }
      FillOrdering chosen;
      std::string message;
      const double ordering_start = cpu();
      if (method != FillOrderingMethod::kAmd) {
        solver.linear_solver_ordering = solverOrdering(Q, method, &chosen, &message);
      }
      const double ordering_cpu = cpu() - ordering_start;
      const std::string warning = "joint: " + message + "; Ceres' own ordering was used";
      if (!message.empty() &&
          std::find(result.notes.begin(), result.notes.end(), warning) == result.notes.end()) {
        result.notes.push_back(warning);  // once, not every round
      }
      if (method == FillOrderingMethod::kAuto) {
        ordering_choice = {true, residuals, chosen.method};
      }
      if (verbose) {
        std::ostringstream o;
        o << "; ordering " << fillOrderingMethodName(chosen.method)
          << (method == fill_method ? "" : " (kept)") << " (CPU " << ordering_cpu << " s)";
        if (chosen.predicted_flops > 0) o << ", predicted " << chosen.predicted_flops << " flops";
        if (chosen.predicted_flops_other > 0) {
          o << " (other " << chosen.predicted_flops_other << ")";
        }
        ordering_note = o.str();
      }
    }
    const double cpu_setup = lap();
    ceres::Solver::Summary summary;
    // Rounds before the last only prepare the next association, outlier
    // rejection and weights: they stop at early_round_max_iterations.
    const bool last_round = round + 1 == max_rounds;
    solver.max_num_iterations =
        last_round || options.early_round_max_iterations == 0
            ? options.max_iterations
            : std::min(options.max_iterations, options.early_round_max_iterations);
    previous_short =
        drift_update_follows && drift_updates > 0 && options.drift_round_max_iterations > 0;
    if (previous_short) {
      solver.max_num_iterations =
          std::min(solver.max_num_iterations, options.drift_round_max_iterations);
    }
    // Verbose: how far the round moved each kind of parameter (the largest move).
    struct Snapshot {
      std::vector<std::array<double, 7>> nodes;
      std::vector<std::array<double, 7>> cameras;
      std::vector<double> offsets, scales;
      std::array<double, 7> x{};
    } before;
    if (verbose) {
      before.nodes = nodes;
      for (const JointCamera& c : cameras) {
        before.cameras.emplace_back();
        std::copy(c.pose, c.pose + 7, before.cameras.back().begin());
        before.offsets.push_back(c.offset_s);
      }
      before.scales = scales;
      std::copy(x_params, x_params + 7, before.x.begin());
    }
    serialiseOpenMpInThisThread();  // CHOLMOD's teams of 4 (core/threads.h)
    ceres::Solve(solver, &Q, &summary);
    if (verbose) {
      auto moved = [](const double* a, const double* b) {
        const double t =
            (Eigen::Vector3d(a[0], a[1], a[2]) - Eigen::Vector3d(b[0], b[1], b[2])).norm();
        const Eigen::Quaterniond qa(a[6], a[3], a[4], a[5]), qb(b[6], b[3], b[4], b[5]);
        return std::make_pair(t, qa.angularDistance(qb) / kDeg);
      };
      double node_t = 0, node_r = 0, camera_t = 0, camera_r = 0, clock = 0, scale = 0;
      for (std::size_t k = 0; k < n_nodes; ++k) {
        const auto [t, r] = moved(nodes[k].data(), before.nodes[k].data());
        node_t = std::max(node_t, t);
        node_r = std::max(node_r, r);
      }
      for (std::size_t c = 0; c < cameras.size(); ++c) {
        const auto [t, r] = moved(cameras[c].pose, before.cameras[c].data());
        camera_t = std::max(camera_t, t);
        camera_r = std::max(camera_r, r);
        clock = std::max(clock, std::abs(cameras[c].offset_s - before.offsets[c]));
      }
      for (std::size_t j = 0; j < scales.size(); ++j) {
        scale = std::max(scale, std::abs(scales[j] - before.scales[j]));
      }
      const auto [x_t, x_r] = moved(x_params, before.x.data());
      std::cerr << "joint round " << round + 1 << ": largest moves: node " << node_t << " m, "
                << node_r << " deg; camera " << camera_t << " m, " << camera_r << " deg; clock "
                << clock * 1e3 << " ms; scale " << scale << "; fisheye_from_marker " << x_t
                << " m, " << x_r << " deg\n";
    }
    previous_converged = summary.termination_type == ceres::CONVERGENCE;
    if (verbose) {
      std::cerr << "joint round " << round + 1 << ": CPU " << cpu_setup
                << " s association and setup, " << lap() << " s solve (preprocessor "
                << summary.preprocessor_time_in_seconds << " s wall, residuals "
                << summary.residual_evaluation_time_in_seconds
                << " s wall): " << summary.BriefReport() << " residual blocks "
                << Q.NumResidualBlocks() << ", time " << summary.total_time_in_seconds
                << " s (jacobians " << summary.jacobian_evaluation_time_in_seconds
                << " s, linear solver " << summary.linear_solver_time_in_seconds << " s)"
                << ordering_note << "\n";
      if (round == 0 || verbose_every_round) {
        std::cerr << summary.FullReport() << "\n";
      }
      std::cerr << "joint round " << round + 1 << ": final cost of odometry, markers, blobs:";
      for (const auto& ids : group_blocks) {
        ceres::Problem::EvaluateOptions eo;
        eo.residual_blocks = ids;
        double group_cost = 0;
        Q.Evaluate(eo, &group_cost, nullptr, nullptr, nullptr);
        std::cerr << " " << group_cost << " (" << ids.size() << " blocks)";
      }
      std::cerr << "\n";
    }
    if (!summary.IsSolutionUsable()) {
      throw Error("joint: the solver failed: " + summary.message);
    }
    drift_model_changed = false;
    if (drift_update_follows) {
      drift_model_changed = updateDriftModel(Q);
      if (!drift_model_failed) ++drift_updates;
      drift_still_changing = drift_model_changed;
    }
  }

  if (options.estimate_drift_model && !options.fix_trajectory) {
    DriftModelEstimate e;
    e.horizontal = drift_factor[0];
    e.vertical = drift_factor[1];
    e.tilt = drift_factor[2];
    e.yaw = drift_factor[3];
    e.updates = drift_updates;
    result.observability.drift_model = e;
    auto sigmaFactor = [](double f) { return formatFixed(f, f < 0.1 ? 3 : 2); };
    result.observability.message +=
        (result.observability.message.empty() ? "" : " ") +
        std::string("joint: the drift model estimated from the data (") +
        std::to_string(drift_updates) + " updates" +
        (drift_still_changing ? ", the last still changing it by more than 10 %" : "") +
        ") is the configured one with its sigmas times " + sigmaFactor(e.horizontal) +
        " horizontally, " + sigmaFactor(e.vertical) + " vertically, " + sigmaFactor(e.tilt) +
        " in tilt and " + sigmaFactor(e.yaw) + " in yaw.";
  }
  for (int kind = 0; kind < 2; ++kind) {
    if (variance_factor[kind] > 1.5) {
      std::ostringstream w;
      w << std::setprecision(3) << "joint: the marker " << (kind ? "corners'" : "poses'")
        << " residuals are " << variance_factor[kind]
        << "x (in variance) what the detector's covariance says (median chi-square); they were "
           "weighted and rejected with that factor";
      result.notes.push_back(w.str());
    }
  }

  // ---- what each camera used ----
  std::vector<int> used(cameras.size(), 0), rejected(cameras.size(), 0);
  for (const Detection& d : detections) {
    if (!d.in_range) continue;
    (d.inlier ? used : rejected)[d.camera]++;
  }
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    if (used[c] < options.min_detections) {
      ceres_problem->SetParameterBlockConstant(cameras[c].pose);
      ceres_problem->SetParameterBlockConstant(&cameras[c].offset_s);
    }
  }

  // ---- covariance (the gauge: the first node is constant) ----
  const bool scales_free = !options.fix_trajectory;
  std::vector<std::pair<const double*, const double*>> blocks;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    if (used[c] < options.min_detections) continue;
    blocks.emplace_back(cameras[c].pose, cameras[c].pose);
    if (options.estimate_clock_offsets) {
      blocks.emplace_back(&cameras[c].offset_s, &cameras[c].offset_s);
    }
  }
  // Every pair of camera poses too, for the gauge-free prediction below (the
  // pairs are dense: their cost grows like the cube of the cameras).
  std::vector<std::size_t> aligned_cameras;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    if (used[c] >= options.min_detections) aligned_cameras.push_back(c);
  }
  const bool aligned_prediction =
      aligned_cameras.size() >= 3 &&
      aligned_cameras.size() <= static_cast<std::size_t>(options.aligned_uncertainty_max_cameras);
  if (aligned_prediction) {
    for (std::size_t a = 0; a < aligned_cameras.size(); ++a) {
      for (std::size_t b = a + 1; b < aligned_cameras.size(); ++b) {
        blocks.emplace_back(cameras[aligned_cameras[a]].pose, cameras[aligned_cameras[b]].pose);
      }
    }
  }
  if (!options.fix_fisheye_from_marker) blocks.emplace_back(x_params, x_params);
  const bool scale_covariance = visual && scales_free && n_segments <= 200;
  if (scale_covariance) {
    for (std::size_t i = 0; i < n_segments; ++i) {
      for (std::size_t j = i; j < n_segments; ++j) blocks.emplace_back(&scales[i], &scales[j]);
    }
  }
  SparseCovariance covariance;
  bool have_covariance = false;
  if (options.covariance && !blocks.empty()) {
    progress.report("joint", max_rounds, max_rounds, "covariance");
    frame_poses->PrepareForEvaluation(true, true);  // (Problem::Evaluate calls it too)
    lap();
    have_covariance = covariance.compute(blocks, ceres_problem.get(), options.threads);
    if (verbose)
      std::cerr << "joint covariance: CPU " << lap() << " s" << covariance.describe() << "\n";
    if (!have_covariance) {
      result.warnings.push_back("joint: the covariance could not be computed (" +
                                covariance.message() +
                                "): the registration has no uncertainty; check the cameras "
                                "with few detections");
    }
  }
  auto poseCovariance = [&](const double* block) {
    return Matrix6d(covariance.block(block, block));
  };
  // The cameras' position RMSE the covariance predicts after a rigid
  // alignment to any reference (what `lookboth evaluate` reports as aligned):
  // the positions' joint covariance C with the linearised alignment
  // (dp_i = t + w x p_i, least squares over the cameras) projected out,
  // sqrt(trace(P C P) / n) with P = I - A (A^T A)^-1 A^T.
  std::map<std::size_t, Eigen::Matrix3d> aligned_position_covariance;  // by camera index
  if (have_covariance && aligned_prediction) {
    const std::size_t n = aligned_cameras.size();
    Eigen::MatrixXd C(3 * n, 3 * n), A(3 * n, 6);
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (std::size_t c : aligned_cameras)
      centroid += Eigen::Map<const Eigen::Vector3d>(cameras[c].pose);
    centroid /= static_cast<double>(n);
    for (std::size_t a = 0; a < n; ++a) {
      const double* pa = cameras[aligned_cameras[a]].pose;
      for (std::size_t b = a; b < n; ++b) {
        const Eigen::Matrix3d block =
            covariance.block(pa, cameras[aligned_cameras[b]].pose).topLeftCorner<3, 3>();
        C.block<3, 3>(3 * a, 3 * b) = block;
        C.block<3, 3>(3 * b, 3 * a) = block.transpose();
      }
      const Eigen::Vector3d p = Eigen::Map<const Eigen::Vector3d>(pa) - centroid;
      A.block<3, 3>(3 * a, 0).setIdentity();
      A.block<3, 3>(3 * a, 3) << 0, p.z(), -p.y(), -p.z(), 0, p.x(), p.y(), -p.x(), 0;  // -[p]x
    }
    const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(3 * n, 3 * n) -
                              A * (A.transpose() * A).ldlt().solve(A.transpose());
    const Eigen::MatrixXd aligned = P * C * P.transpose();
    result.observability.aligned_position_rmse_m =
        std::sqrt(std::max(0.0, aligned.trace() / static_cast<double>(n)));
    for (std::size_t a = 0; a < n; ++a)
      aligned_position_covariance[aligned_cameras[a]] = aligned.block<3, 3>(3 * a, 3 * a);
  }
  auto scalarVariance = [&](const double* a, const double* b) {
    return covariance.block(a, b)(0, 0);
  };

  // ---- fisheye_from_marker ----
  const Rigid3d X = paramsToPose(x_params);
  problem.fisheye_from_marker = X;
  result.fisheye_from_marker = X;
  {
    std::vector<std::string> notes;
    if (options.fix_fisheye_from_marker) {
      notes.push_back(std::string("joint: fisheye_from_marker held fixed at ") +
                      (options.fisheye_from_marker_from_ground_truth
                           ? "the dataset's ground truth"
                           : "the value of the earlier stages") +
                      " (fix_fisheye_from_marker)");
    } else if (have_covariance) {
      const Matrix6d cov = poseCovariance(x_params);
      result.fisheye_from_marker_covariance = cov;
      std::string undetermined;  // components the data leaves to a prior or free
      bool free_component = false;
      for (int c = 0; c < 6; ++c) {
        const double sigma = std::sqrt(std::max(0.0, cov(c, c)));
        const double prior_sigma =
            c < 3 ? options.prior_translation_sigma_m : options.prior_rotation_sigma_deg * kDeg;
        const double max_sigma =
            c < 3 ? options.max_translation_sigma_m : options.max_rotation_sigma_deg * kDeg;
        const bool by_prior = prior_on[c] && sigma > 0.5 * prior_sigma;
        const bool determined = sigma <= max_sigma && !by_prior;
        result.fisheye_from_marker_determined[c] = determined;
        if (!determined) {
          // Loosely known is worth a note; a warning when the cameras move
          // with it by more than centimetres (or degrees).
          free_component = free_component || (!by_prior && sigma > kLooseFactor * max_sigma);
          undetermined += std::string(undetermined.empty() ? "" : ", ") + kComponentNames[c] +
                          " (sigma " +
                          (c < 3 ? formatFixed(sigma * 1000, 2) + " mm"
                                 : formatFixed(sigma / kDeg, 3) + " deg") +
                          (by_prior ? ", held by the prior of motion_calibration" : "") + ")";
        }
      }
      if (undetermined.empty()) {
        notes.push_back(
            "joint: the detections and blobs determine every component of fisheye_from_marker" +
            std::string(std::any_of(prior_on.begin(), prior_on.end(), [](bool b) { return b; })
                            ? " (the motion-only priors no longer dominate)"
                            : ""));
      } else {
        notes.push_back("joint: not determined by the data: fisheye_from_marker " + undetermined);
        if (free_component) {
          // Nothing holds it: the cameras move with its arbitrary value.
          result.warnings.push_back(
              "joint: fisheye_from_marker " + undetermined +
              " is not determined by the data and no prior holds it: measure the marker's "
              "mount on the robot and set register.motion_calibration.prior_translation_m / "
              "prior_rotation_xyzw, or drive with more turns and slopes");
        } else {
          // A flat floor cannot determine the marker's height (or tilt):
          // expected, and the configured mount then decides it.
          result.notes.push_back("joint: fisheye_from_marker " + undetermined +
                                 ": loosely determined, or held by the configured mount where a "
                                 "flat floor cannot determine it (expected)");
        }
      }
    }
    for (const std::string& n : notes) {
      result.observability.message += (result.observability.message.empty() ? "" : " ") + n + ".";
    }
  }

  // ---- scale ----
  if (visual) {
    double mean = 0;
    for (double s : scales) mean += s;
    mean /= static_cast<double>(n_segments);
    problem.scale = mean;
    result.scale = mean;
    if (have_covariance && scale_covariance) {
      double var = 0;
      for (std::size_t i = 0; i < n_segments; ++i) {
        for (std::size_t j = 0; j < n_segments; ++j) {
          var += scalarVariance(&scales[std::min(i, j)], &scales[std::max(i, j)]);
        }
      }
      result.scale_sigma = std::sqrt(std::max(0.0, var)) / static_cast<double>(n_segments);
    }
    double lo = *std::min_element(scales.begin(), scales.end());
    double hi = *std::max_element(scales.begin(), scales.end());
    if (n_segments > 1) {
      result.observability.message += (result.observability.message.empty() ? "" : " ") +
                                      std::string("joint: the trajectory's scale varies over ") +
                                      std::to_string(n_segments) + " segments of " +
                                      formatDouble(options.scale_segment_m) + " m from " +
                                      formatFixed(lo, 6) + " to " + formatFixed(hi, 6) + ".";
    }
  }

  // ---- the corrected trajectory ----
  {
    std::vector<StampedPose> corrected;
    corrected.reserve(samples.size());
    for (const StampedPose& sample : samples) {
      const auto b = bracketAt(sample.t, false);
      if (!b) continue;
      corrected.push_back({sample.t, evalPose(*b, b->tau_ref_s)});
    }
    problem.metric_trajectory = std::move(corrected);
  }

  // ---- cameras ----
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    JointCamera& jc = cameras[c];
    CameraRegistration& camera = *jc.registration;
    std::vector<std::size_t>& kept = problem.inliers_by_camera[camera.label];
    kept.clear();
    const int n = used[c] + rejected[c];
    camera.detections.used = used[c];
    camera.detections.rejected = rejected[c];
    if (used[c] < options.min_detections) {
      camera.status = CameraStatus::kUnregistered;
      camera.reason = "joint: only " + std::to_string(used[c]) + " of " + std::to_string(n) +
                      " detections are consistent with the joint estimate (at least " +
                      std::to_string(options.min_detections) + " needed)";
      camera.covariance.reset();
      camera.aligned_position_covariance.reset();
      camera.residuals.reset();
      continue;
    }
    if (restarted.count(camera.label)) {
      camera.notes.push_back("joint: registered although look_down was not (" + camera.reason +
                             ")");
    }
    const Rigid3d pose = paramsToPose(jc.pose);
    camera.world_from_camera = pose;
    camera.stage_poses["joint"] = pose;
    camera.covariance.reset();
    if (have_covariance) camera.covariance = poseCovariance(jc.pose);
    camera.aligned_position_covariance.reset();
    if (const auto found = aligned_position_covariance.find(c);
        found != aligned_position_covariance.end()) {
      camera.aligned_position_covariance = found->second;
    }
    ClockOffsetEstimate offset;
    offset.offset_ns = static_cast<TimeNs>(std::llround(jc.offset_s * 1e9));
    offset.estimated = options.estimate_clock_offsets;
    if (have_covariance && options.estimate_clock_offsets) {
      offset.sigma_ms = std::sqrt(std::max(0.0, scalarVariance(&jc.offset_s, &jc.offset_s))) * 1e3;
      if (offset.sigma_ms > options.max_clock_sigma_ms) {
        camera.warnings.push_back(
            "joint: the clock offset is uncertain (sigma " + formatFixed(offset.sigma_ms, 1) +
            " ms, more than max_clock_sigma_ms " + formatFixed(options.max_clock_sigma_ms, 1) +
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
    double sum_p = 0, sum_r = 0;
    for (std::size_t i : jc.detections) {
      const Detection& d = detections[i];
      if (!d.in_range || !d.inlier) continue;
      kept.push_back(d.association);
      const Bracket& b = *det_bracket[i];
      const double tau = nsToSeconds(d.t_camera - node_t[b.k]) - jc.offset_s;
      const Rigid3d by_robot = evalPose(b, tau) * X;
      const Rigid3d by_camera =
          pose * problem.marker(problem.associations[d.association]).camera_from_marker;
      sum_p += (by_camera.translation - by_robot.translation).squaredNorm();
      const double angle =
          calib_detail::angleOf(by_camera.rotation.conjugate() * by_robot.rotation);
      sum_r += angle * angle;
    }
    camera.residuals = ResidualStats{std::sqrt(sum_p / used[c]), std::sqrt(sum_r / used[c]) / kDeg};
    const double rejected_fraction = n > 0 ? static_cast<double>(rejected[c]) / n : 0.0;
    if (rejected_fraction > 0.3) {
      camera.status = CameraStatus::kSuspect;
      camera.reason = "joint: " + std::to_string(rejected[c]) + " of " + std::to_string(n) +
                      " detections disagree with the joint estimate";
    } else if (used[c] < 8) {
      camera.status = CameraStatus::kSuspect;
      camera.reason = "only " + std::to_string(used[c]) + " consistent detections";
    } else {
      camera.status = CameraStatus::kRegistered;
      camera.reason.clear();
    }
    if (jc.blobs > 0 && jc.blobs < options.min_blobs) {
      camera.notes.push_back("joint: only " + std::to_string(jc.blobs) +
                             " blobs associated; not used");
    }
  }

  // ---- fisheye reprojection of the camera positions ----
  // The paper's Table I for the final result: "before" = look_down's position
  // on the input trajectory (motion_calibration's scale), "after" = the joint
  // estimate on the corrected trajectory, over the blobs associated at the
  // joint estimate. They replace look_up's statistics and rows of
  // blob_associations.csv for the cameras of this stage.
  if (use_blobs) {
    associateBlobs();
    auto projectFrom = [&](const Rigid3d& world_from_fisheye,
                           const Eigen::Vector3d& p_in_world) -> std::optional<Eigen::Vector2d> {
      const Eigen::Vector3d p = world_from_fisheye.inverse() * p_in_world;
      if (p.z() <= 0) return std::nullopt;
      return fisheye->project(p);
    };
    std::set<std::string> labels;
    std::vector<BlobAssociation> rows;
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      CameraRegistration& camera = *cameras[c].registration;
      labels.insert(camera.label);
      camera.reprojection.reset();
      if (camera.status == CameraStatus::kUnregistered) continue;
      const auto look_down = camera.stage_poses.find("look_down");
      const Rigid3d before_pose =
          look_down != camera.stage_poses.end() ? look_down->second : cameras[c].start;
      const Eigen::Vector3d before_in_world = before_pose * options.blob_offset_in_camera_m;
      const Eigen::Vector3d after_in_world =
          camera.world_from_camera * options.blob_offset_in_camera_m;
      int n = 0;
      double sum_before = 0, sum_after = 0;
      for (const BlobMatch& m : matches[c]) {
        const Frame& f = frames[m.frame];
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
    std::vector<BlobAssociation>& all = result.blob_associations;
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
    for (const CameraRegistration& camera : result.cameras) {
      if (!camera.reprojection || camera.reprojection->blobs == 0) continue;
      const ReprojectionStats& st = *camera.reprojection;
      blobs += st.blobs;
      before2 += st.rms_px_before * st.rms_px_before * st.blobs;
      after2 += st.rms_px_after * st.rms_px_after * st.blobs;
    }
    if (blobs > 0) {
      result.reprojection =
          ReprojectionStats{blobs, std::sqrt(before2 / blobs), std::sqrt(after2 / blobs), "joint"};
    } else {
      result.reprojection.reset();
    }
  }
  progress.report("joint", max_rounds, max_rounds);
}

}  // namespace lookboth
