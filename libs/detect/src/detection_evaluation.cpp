#include "lookboth/detect/detection_evaluation.h"

#include <algorithm>
#include <cmath>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/pose_perturbation.h"
#include "lookboth/geometry/time.h"

namespace lookboth {

namespace {
constexpr double kDeg = 3.14159265358979323846 / 180.0;

// A detection's error as a perturbation of its camera's pose
// (geometry/pose_perturbation.h), the quantity a pass's errors must average
// out in.
struct WeightedError {
  TimeNs t = 0;
  Vector6d delta;
  Matrix6d information;

  WeightedError(TimeNs stamp, const Rigid3d& camera_from_marker, const Vector6d& e,
                const Matrix6d& info)
      : t(stamp),
        delta(cameraPerturbationFromMarkerError(camera_from_marker) * e),
        information(informationOnCameraPose(camera_from_marker, info)) {}
};

// MarkerEvaluation::mean_pass_nees: a pass ends at a gap of over a second.
void scorePasses(std::map<std::string, std::vector<WeightedError>>& errors_by_camera,
                 MarkerEvaluation& out) {
  constexpr TimeNs kPassGap = kNanosecondsPerSecond;
  constexpr size_t kMinDetections = 3;
  double nees_sum = 0, detections_sum = 0;
  for (auto& [camera, errors] : errors_by_camera) {
    std::sort(errors.begin(), errors.end(),
              [](const WeightedError& a, const WeightedError& b) { return a.t < b.t; });
    std::vector<TimeNs> times;
    for (const WeightedError& e : errors) times.push_back(e.t);
    for (const auto& [begin, end] : runsWithinGap(times, kPassGap)) {
      if (end - begin < kMinDetections) continue;
      Matrix6d h = Matrix6d::Zero();
      Vector6d g = Vector6d::Zero();
      for (size_t i = begin; i < end; ++i) {
        h += errors[i].information;
        g += errors[i].information * errors[i].delta;
      }
      nees_sum += g.dot(h.ldlt().solve(g));
      detections_sum += static_cast<double>(end - begin);
      ++out.passes;
    }
  }
  if (out.passes > 0) {
    out.mean_pass_nees = nees_sum / out.passes;
    out.mean_pass_detections = detections_sum / out.passes;
    // The detections' own scale (mean NEES / 6) factored out: beta is what
    // their covariance, however scaled, leaves out.
    const double scale = out.mean_nees > 0 ? out.mean_nees / 6.0 : 1.0;
    out.pass_error_share =
        std::max(0.0, (nees_sum / scale - 6.0 * out.passes) / (6.0 * detections_sum));
  }
}

// BlobEvaluation::pass_error_share: per camera, its matched blobs with no gap
// over a second form a pass; a pass's mean error e_p of n_p blobs has
// n_p |e_p|^2 / s^2 = 2 (1 + beta n_p) on average, s^2 the per-coordinate
// variance of one blob's error, from the median (|e|^2 is s^2 chi-square 2,
// median 2 ln 2 s^2) so that the few gross errors within the match radius do
// not set it.
void scoreBlobPasses(
    std::map<std::string, std::vector<std::pair<TimeNs, Eigen::Vector2d>>>& by_camera,
    const std::vector<double>& distances, BlobEvaluation& out) {
  constexpr TimeNs kPassGap = kNanosecondsPerSecond;
  const double median = medianOf(distances);
  const double s2 = median * median / (2 * std::log(2.0));
  if (!(s2 > 0)) return;
  double nees_sum = 0, count = 0;
  for (auto& [camera, errors] : by_camera) {
    std::sort(errors.begin(), errors.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<TimeNs> times;
    for (const auto& e : errors) times.push_back(e.first);
    for (const auto& [begin, end] : runsWithinGap(times, kPassGap)) {
      if (end - begin < 3) continue;
      Eigen::Vector2d sum = Eigen::Vector2d::Zero();
      for (size_t i = begin; i < end; ++i) sum += errors[i].second;
      const double n = static_cast<double>(end - begin);
      nees_sum += sum.squaredNorm() / n / s2;
      count += n;
      ++out.passes;
    }
  }
  if (out.passes > 0) {
    out.mean_pass_nees = nees_sum / out.passes;
    out.pass_error_share = std::max(0.0, (nees_sum - 2.0 * out.passes) / (2.0 * count));
    out.shared_error_px = std::sqrt(out.pass_error_share * s2);
  }
}
}  // namespace

double medianOf(std::vector<double> values) { return quantileOf(std::move(values), 0.5); }

double quantileOf(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto i =
      static_cast<size_t>(std::clamp(std::ceil(q * static_cast<double>(values.size())) - 1, 0.0,
                                     static_cast<double>(values.size() - 1)));
  return values[i];
}

std::optional<Rigid3d> GroundTruthView::cameraFromMarker(const std::string& camera,
                                                         TimeNs t) const {
  if (!manifest.ground_truth.fisheye_from_marker) return std::nullopt;
  const auto pose = manifest.ground_truth.world_from_camera.find(camera);
  if (pose == manifest.ground_truth.world_from_camera.end()) return std::nullopt;
  TimeNs offset = 0;
  if (const auto o = manifest.ground_truth.clock_offset.find(camera);
      o != manifest.ground_truth.clock_offset.end()) {
    offset = o->second;
  }
  const InterpolationResult at = world_from_fisheye.interpolate(t - offset, 0);
  if (!at.ok()) return std::nullopt;
  return pose->second.inverse() * at.world_from_body * *manifest.ground_truth.fisheye_from_marker;
}

MarkerEvaluation evaluateMarkers(const GroundTruthView& truth,
                                 const std::vector<MarkerObservation>& detections,
                                 const std::vector<std::pair<std::string, TimeNs>>& frames,
                                 const std::vector<double>& band_edges, double min_side_px) {
  MarkerEvaluation out;
  const double side = truth.manifest.marker.size_m;
  std::map<std::pair<std::string, TimeNs>, bool> visible;
  for (const auto& [camera, t] : frames) {
    const CameraSensor* sensor = truth.manifest.findCamera(camera);
    const auto pose = truth.cameraFromMarker(camera, t);
    bool in_view = sensor && sensor->camera && pose;
    if (in_view) {
      const Eigen::Vector3d normal = pose->rotation * Eigen::Vector3d::UnitZ();
      in_view = normal.dot(-pose->translation.normalized()) > std::cos(60 * kDeg);
      const double h = side / 2;
      const Eigen::Vector3d corners[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
      Eigen::Vector2d px[4];
      for (int k = 0; k < 4 && in_view; ++k) {
        const auto p = sensor->camera->project(*pose * corners[k]);
        in_view = p && sensor->camera->isInImage(*p, 2.0);
        if (p) px[k] = *p;
      }
      for (int k = 0; k < 4 && in_view; ++k) {
        in_view = (px[(k + 1) % 4] - px[k]).norm() >= min_side_px;
      }
    }
    visible[{camera, t}] = in_view;
    out.visible_frames += in_view ? 1 : 0;
  }
  const size_t bands = band_edges.size() > 1 ? band_edges.size() - 1 : 0;
  std::vector<std::vector<double>> position(bands + 1), in_plane(bands + 1), tilt(bands + 1),
      along(bands + 1);
  std::map<std::pair<std::string, TimeNs>, bool> found;
  double nees_sum = 0;
  int nees_count = 0;
  std::map<std::string, std::vector<WeightedError>> errors_by_camera;
  for (const MarkerObservation& d : detections) {
    if (d.marker_id != truth.manifest.marker.id) continue;  // a fixed marker: not the robot's
    ++out.detections;
    const auto pose = truth.cameraFromMarker(d.camera, d.t);
    if (!pose) continue;
    const Eigen::Vector3d dt = pose->translation - d.camera_from_marker.translation;
    if (dt.norm() > 0.1) {
      ++out.false_positives;
      out.false_positive_notes.push_back(d.camera + " @ " + formatSeconds(d.t) +
                                         " s: " + formatFixed(dt.norm(), 3) + " m off");
      continue;
    }
    const auto key = std::make_pair(d.camera, d.t);
    if (visible.count(key) && visible[key] && !found[key]) {
      found[key] = true;
      ++out.detected_frames;
    }
    // Error in the estimate's frame: R_true = R * Exp(dtheta).
    const Eigen::Vector3d dtheta =
        so3Log(Eigen::Quaterniond(d.camera_from_marker.rotation.conjugate() * pose->rotation));
    Eigen::Matrix<double, 6, 1> e;
    e << dt, dtheta;
    if (!d.information.isZero()) {
      nees_sum += e.dot(d.information * e);
      ++nees_count;
      errors_by_camera[d.camera].emplace_back(d.t, d.camera_from_marker, e, d.information);
    }
    const double distance = pose->translation.norm();
    const Eigen::Matrix3d relative =
        pose->rotation.toRotationMatrix().transpose() * d.camera_from_marker.rotation;
    const double in_plane_deg = std::abs(std::atan2(relative(1, 0), relative(0, 0))) / kDeg;
    const double tilt_deg = std::acos(std::clamp(relative(2, 2), -1.0, 1.0)) / kDeg;
    const double along_mm = -1000 * dt.dot(pose->translation.normalized());
    for (size_t b = 0; b <= bands; ++b) {
      const bool all = b == bands;
      if (!all && !(distance >= band_edges[b] && distance < band_edges[b + 1])) continue;
      position[b].push_back(1000 * dt.norm());
      in_plane[b].push_back(in_plane_deg);
      tilt[b].push_back(tilt_deg);
      along[b].push_back(along_mm);
    }
  }
  for (size_t b = 0; b <= bands; ++b) {
    MarkerErrorBand band;
    band.min_distance_m =
        b == bands ? (band_edges.empty() ? 0 : band_edges.front()) : band_edges[b];
    band.max_distance_m =
        b == bands ? (band_edges.empty() ? 0 : band_edges.back()) : band_edges[b + 1];
    band.count = static_cast<int>(position[b].size());
    band.median_position_mm = medianOf(position[b]);
    band.p90_position_mm = quantileOf(position[b], 0.9);
    band.median_in_plane_deg = medianOf(in_plane[b]);
    band.median_tilt_deg = medianOf(tilt[b]);
    band.median_along_sight_mm = medianOf(along[b]);
    out.bands.push_back(band);
  }
  out.mean_nees = nees_count ? nees_sum / nees_count : 0.0;
  scorePasses(errors_by_camera, out);
  return out;
}

GroundTruthView loadGroundTruth(const std::filesystem::path& dataset) {
  auto reader = DatasetReader::open(dataset);
  GroundTruthView view;
  view.manifest = reader->manifest();
  if (view.manifest.ground_truth.world_from_camera.empty() ||
      !view.manifest.ground_truth.fisheye_from_marker) {
    throw Error({dataset.string(), 0, "ground_truth", ""},
                "the manifest has no ground truth (world_from_camera, fisheye_from_marker): "
                "only simulated datasets can be evaluated");
  }
  std::vector<StampedPose> samples;
  while (auto record = reader->next()) {
    if (const auto* pose = std::get_if<PoseSample>(&*record);
        pose && pose->label == "ground_truth") {
      if (samples.empty() || pose->t > samples.back().t)
        samples.push_back({pose->t, pose->world_from_body});
    }
  }
  if (samples.empty()) {
    throw Error({dataset.string(), 0, "", "ground_truth"}, "no ground_truth trajectory");
  }
  view.world_from_fisheye = Trajectory(std::move(samples));
  return view;
}

namespace {

/// The blob nearest `p` within `match_px` not used yet, or -1.
int nearestUnused(const std::vector<Blob>& blobs, const std::vector<bool>& used,
                  const Eigen::Vector2d& p, double match_px) {
  int best = -1;
  double best_distance = match_px;
  for (size_t i = 0; i < blobs.size(); ++i) {
    const double distance = (Eigen::Vector2d(blobs[i].u, blobs[i].v) - p).norm();
    if (!used[i] && distance < best_distance) {
      best_distance = distance;
      best = static_cast<int>(i);
    }
  }
  return best;
}

}  // namespace

BlobEvaluation evaluateBlobs(const GroundTruthView& truth,
                             const std::vector<BlobObservation>& observations, double match_px,
                             const std::vector<double>& band_edges) {
  BlobEvaluation out;
  out.knows_hidden = !truth.manifest.ground_truth.hidden_from_fisheye.empty();
  for (size_t b = 0; b + 1 < band_edges.size(); ++b) {
    out.bands.push_back({band_edges[b], band_edges[b + 1]});
  }
  std::vector<std::vector<double>> band_errors(out.bands.size());
  std::vector<double> errors;
  std::map<std::string, std::vector<std::pair<TimeNs, Eigen::Vector2d>>> by_camera;
  for (const BlobObservation& obs : observations) {
    const CameraSensor* sensor = truth.manifest.findCamera(obs.camera);
    if (!sensor || !sensor->camera) continue;
    TimeNs offset = 0;
    if (const auto o = truth.manifest.ground_truth.clock_offset.find(obs.camera);
        o != truth.manifest.ground_truth.clock_offset.end()) {
      offset = o->second;
    }
    const InterpolationResult at = truth.world_from_fisheye.interpolate(obs.t - offset, 0);
    if (!at.ok()) continue;
    ++out.frames;
    const Rigid3d fisheye_from_world = at.world_from_body.inverse();
    std::vector<bool> used(obs.blobs.size(), false);
    // The housings the fisheye sees take their blobs first; a hidden one
    // may then take a blob left (its dome's rim past the obstacle).
    std::vector<Eigen::Vector2d> hidden;
    for (const auto& [label, world_from_camera] : truth.manifest.ground_truth.world_from_camera) {
      const Eigen::Vector3d centre = fisheye_from_world * world_from_camera.translation;
      const auto p = sensor->camera->project(centre);
      if (!p || !sensor->camera->isInImage(*p, 2.0)) continue;
      if (truth.manifest.ground_truth.hiddenFromFisheye(label, obs.t)) {
        hidden.push_back(*p);
        continue;
      }
      ++out.expected;
      const double distance = centre.norm();
      BlobBand* band = nullptr;
      for (BlobBand& b : out.bands) {
        if (distance >= b.min_distance_m && distance < b.max_distance_m) band = &b;
      }
      if (band) ++band->expected;
      const int best = nearestUnused(obs.blobs, used, *p, match_px);
      if (best >= 0) {
        const Blob& nearest = obs.blobs[static_cast<size_t>(best)];
        const double best_distance = (Eigen::Vector2d(nearest.u, nearest.v) - *p).norm();
        used[static_cast<size_t>(best)] = true;
        ++out.matched;
        errors.push_back(best_distance);
        if (band) {
          ++band->matched;
          band_errors[static_cast<size_t>(band - out.bands.data())].push_back(best_distance);
        }
        const Blob& blob = obs.blobs[static_cast<size_t>(best)];
        by_camera[label].push_back({obs.t, Eigen::Vector2d(blob.u, blob.v) - *p});
      }
    }
    for (const Eigen::Vector2d& p : hidden) {
      ++out.hidden;
      const int near = nearestUnused(obs.blobs, used, p, match_px);
      if (near >= 0) {
        used[static_cast<size_t>(near)] = true;
        ++out.hidden_matched;
      }
    }
    for (const bool u : used) out.false_positives += u ? 0 : 1;
  }
  out.median_error_px = medianOf(errors);
  out.p90_error_px = quantileOf(errors, 0.9);
  for (size_t b = 0; b < out.bands.size(); ++b) {
    out.bands[b].median_error_px = medianOf(band_errors[b]);
  }
  scoreBlobPasses(by_camera, errors, out);
  return out;
}

}  // namespace lookboth
