// Stage `joint`: the clock searches of the cameras look_down could not
// register (joint_adjustment.h). Detections that disagree (e.g. a clock off
// by 100s of ms: look_down found the camera suspect or could not register
// it) may agree once the offset is estimated: such a camera starts from the
// offset that makes them agree best and the median of the per-detection
// poses world_from_marker * camera_from_marker^-1.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>

#include "joint_adjustment.h"

namespace lookboth::joint_detail {
namespace {

// A blob frame and world_from_fisheye there.
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

// The camera poses the detections `associations` give (shareMeanRotation)
// with world_from_fisheye = pose_at(time_of(association)) and
// fisheye_from_marker X, and their median position; false when fewer than
// `min_detections` have a pose.
template <typename PoseAt, typename TimeOf>
bool detectionCameraPoses(const RegistrationProblem& problem,
                          const std::vector<std::size_t>& associations, const PoseAt& pose_at,
                          const TimeOf& time_of, const Rigid3d& X, int min_detections,
                          std::vector<Rigid3d>& candidates, Eigen::Vector3d& median) {
  candidates.clear();
  std::vector<Eigen::Vector3d> marker_in_camera;
  for (std::size_t a : associations) {
    const Association& as = problem.associations[a];
    const auto w = pose_at(time_of(as));
    if (!w) continue;
    candidates.push_back(*w * X * problem.marker(as).camera_from_marker.inverse());
    marker_in_camera.push_back(problem.marker(as).camera_from_marker.translation);
  }
  if (static_cast<int>(candidates.size()) < min_detections) return false;
  shareMeanRotation(candidates, marker_in_camera);
  median = medianPosition(candidates);
  return true;
}

}  // namespace

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

// Of the trial shifts with their detections' spreads [m] and blob scores
// [px] (NaN: none), the one the restart takes: among those whose spread is
// within 1.5x or 2 cm of the least, the one whose blobs agree best with the
// camera they put there (without blobs the least spread); the configured
// offset (shift 0) stays when its own spread is admissible (the detections
// agree there: the blobs, seen along a path not yet corrected, would let the
// odometry's drift pass for a clock offset; the search after the first round
// judges them on the corrected path), or unless the chosen one is clearly
// better: by the blobs, 1 px or 10 % of its score, else by the spread, 1.5x
// (the scores are noisy and flat along one pass).
std::size_t chooseShift(const std::vector<double>& shifts, const std::vector<double>& spreads,
                        const std::vector<double>& blob_scores, double* admissible_m) {
  const double least = *std::min_element(spreads.begin(), spreads.end());
  const double admissible = std::max(1.5 * least, least + 0.02);
  if (admissible_m != nullptr) *admissible_m = admissible;
  // Whether shift i beats shift j: by the blobs when both have a score (by
  // more than `margin_px` or `ratio` of j's), else by the spread (`factor`
  // times smaller); `by_score`: a score beats none.
  auto beats = [&](std::size_t i, std::size_t j, double margin_px, double ratio, double factor,
                   bool by_score) {
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
  const auto zero = std::find(shifts.begin(), shifts.end(), 0.0);
  if (zero != shifts.end()) {
    const std::size_t z = static_cast<std::size_t>(zero - shifts.begin());
    if (spreads[z] <= admissible || !beats(chosen, z, 1.0, 0.1, 1.5, false)) chosen = z;
  }
  return chosen;
}

std::optional<std::pair<Rigid3d, double>> JointAdjustment::restartCamera(
    const CameraRegistration& c) const {
  const auto found = problem_.associations_by_camera.find(c.label);
  if (found == problem_.associations_by_camera.end() ||
      static_cast<int>(found->second.size()) < options_.min_detections) {
    return std::nullopt;
  }
  const auto reference_at = [this](TimeNs t) { return referenceAt(t); };
  // The per-detection poses at a trial clock offset [s] (relative to the
  // configured one), their median position and spread.
  auto trial = [&](double shift_s, std::vector<Rigid3d>& candidates, Eigen::Vector3d& median) {
    const auto time_of = [&](const Association& as) {
      return as.t_robot - static_cast<TimeNs>(std::llround(shift_s * 1e9));
    };
    if (!detectionCameraPoses(problem_, found->second, reference_at, time_of, X0_,
                              options_.min_detections, candidates, median)) {
      return 1e300;
    }
    return medianDistance(candidates, median);
  };
  // The fisheye's view of a trial position: over the blob frames around
  // the camera's detections, the mean distance from its projection to
  // the nearest blob, truncated [px]; NaN with too few frames seeing it.
  // (A pass in one direction moves every per-detection pose alike when the
  // clock shifts: their spread cannot tell the offset, the blobs can; here
  // they decide only when the spread at the configured offset is not
  // admissible, and the search after the first round, on the corrected
  // path, judges a single pass.)
  TimeNs t_first = std::numeric_limits<TimeNs>::max(), t_last = 0;
  for (std::size_t a : found->second) {
    t_first = std::min(t_first, problem_.associations[a].t_robot);
    t_last = std::max(t_last, problem_.associations[a].t_robot);
  }
  std::vector<BlobView> views;
  if (blob_fisheye_ != nullptr) views = blobViews(input_.blobs, t_first, t_last, reference_at);
  auto blobScore = [&](const Eigen::Vector3d& p_in_world) -> double {
    if (blob_fisheye_ == nullptr) return std::numeric_limits<double>::quiet_NaN();
    return nearestBlobScore(*blob_fisheye_, views, p_in_world, 30.0);
  };
  // With estimated clocks: the offset within +-0.5 s (10 ms steps) that
  // chooseShift takes.
  double best_shift = 0;
  std::vector<Rigid3d> candidates;
  Eigen::Vector3d median;
  double best = trial(0.0, candidates, median);
  if (options_.estimate_clock_offsets) {
    std::vector<double> shifts, spreads, blob_scores;
    for (int k = -50; k <= 50; ++k) {
      const double spread = trial(0.01 * k, candidates, median);
      if (spread >= 1e300) continue;
      shifts.push_back(0.01 * k);
      spreads.push_back(spread);
      blob_scores.push_back(blobScore(median));
    }
    if (!shifts.empty()) {
      double admissible = 0;
      const std::size_t chosen = chooseShift(shifts, spreads, blob_scores, &admissible);
      best = spreads[chosen];
      best_shift = shifts[chosen];
      if (verbose_) {
        std::cerr << "joint clock search " << c.label << ": chose " << best_shift * 1e3
                  << " ms (spread admissible below " << admissible << " m)\n";
        for (std::size_t i = 0; i < shifts.size(); i += 5) {
          std::cerr << "  " << shifts[i] * 1e3 << " ms: spread " << spreads[i] << " m, blobs "
                    << blob_scores[i] << " px\n";
        }
      }
    }
  }
  if (best >= 1e300) return std::nullopt;
  trial(best_shift, candidates, median);
  std::vector<Eigen::Quaterniond> rotations;
  for (const Rigid3d& r : candidates) rotations.push_back(r.rotation);
  return std::make_pair(Rigid3d(calib_detail::meanRotation(rotations), median), best_shift);
}

void JointAdjustment::researchRestartedClocks() {
  const auto pose_now = [this](TimeNs t) -> std::optional<Rigid3d> {
    const auto b = bracketAt(t, false);
    if (!b) return std::nullopt;
    return evalPose(*b, b->tau_ref_s);
  };
  const Rigid3d X = paramsToPose(x_params_);
  for (JointCamera& jc : cameras_) {
    const std::string& label = jc.registration->label;
    if (restarted_.count(label) == 0) continue;
    const auto found = problem_.associations_by_camera.find(label);
    if (found == problem_.associations_by_camera.end()) continue;
    TimeNs t_first = std::numeric_limits<TimeNs>::max(), t_last = 0;
    for (std::size_t a : found->second) {
      t_first = std::min(t_first, problem_.marker(problem_.associations[a]).t);
      t_last = std::max(t_last, problem_.marker(problem_.associations[a]).t);
    }
    const TimeNs shift_now = static_cast<TimeNs>(std::llround(jc.offset_s * 1e9));
    const std::vector<BlobView> views =
        blobViews(input_.blobs, t_first - shift_now, t_last - shift_now, pose_now);
    // At an offset [s]: the per-detection camera poses, their median
    // position, and the mean distance from its projection to the nearest
    // blob, truncated at 10 px (NaN: too few views).
    auto score = [&](double offset_s, std::vector<Rigid3d>& candidates, Eigen::Vector3d& median) {
      const auto time_of = [&](const Association& as) {
        return problem_.marker(as).t - static_cast<TimeNs>(std::llround(offset_s * 1e9));
      };
      if (!detectionCameraPoses(problem_, found->second, pose_now, time_of, X,
                                options_.min_detections, candidates, median)) {
        return std::numeric_limits<double>::quiet_NaN();
      }
      return nearestBlobScore(*blob_fisheye_, views, median, 10.0);
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
    // A move must halve the blobs' score: a real odometry's drift left in
    // the corrected path improves it by a fifth to a third at a wrong offset
    // (doc/benchmarks.md, "Real drift"); a clock truly off brings it near
    // the blobs' noise.
    const double spread_now = spread(jc.offset_s), spread_best = spread(best_offset);
    const bool move = !std::isnan(best) && best_offset != jc.offset_s &&
                      (std::isnan(now) || best < now - std::max(1.0, 0.5 * now)) &&
                      spread_now < kMaxSpread && spread_best <= 1.2 * spread_now + 0.005;
    if (verbose_) {
      std::cerr << "joint clock search after round 1 " << label << ": offset " << jc.offset_s * 1e3
                << " ms scores " << now << " px (spread " << spread_now << " m); best "
                << best_offset * 1e3 << " ms " << best << " px (spread " << spread_best << " m)"
                << (move ? " (moved)" : "") << "\n";
    }
    if (!move) continue;
    score(best_offset, candidates, median);
    std::vector<Eigen::Quaterniond> rotations;
    for (const Rigid3d& r : candidates) rotations.push_back(r.rotation);
    poseToParams(Rigid3d(calib_detail::meanRotation(rotations), median), jc.pose);
    jc.offset_s = best_offset;
    jc.judgeClock();
    restarted_now_[static_cast<std::size_t>(&jc - cameras_.data())] = true;
  }
}

}  // namespace lookboth::joint_detail
