// The odometry: tracking, initialisation, keyframes, local adjustment, loss
// and recovery. Loop closure lives in loop_closure.cpp.
#include "lookboth/vo/odometry.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iterator>
#include <numeric>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <random>

#include "lookboth/core/error.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/umeyama.h"
#include "lookboth/vo/bearing_geometry.h"
#include "loop_closure.h"
#include "map.h"

namespace lookboth::vo {
namespace {

constexpr double kDeg = M_PI / 180.0;

/// Accumulates the CPU time of the calling thread per stage [s]: on a shared
/// machine wall time says more about the other jobs than about this one.
class StageTimer {
 public:
  StageTimer(std::map<std::string, double>& sink, const char* stage)
      : sink_(sink), stage_(stage), start_(threadCpuSeconds()) {}
  ~StageTimer() { sink_[stage_] += threadCpuSeconds() - start_; }

 private:
  std::map<std::string, double>& sink_;
  const char* stage_;
  double start_;
};

struct Track {
  int id = 0;
  cv::Point2f px;  ///< Working-resolution pixel in the current frame.
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();  ///< In the current frame.
  int landmark = -1;                                   ///< Map landmark, or -1 (pending).
  int first_keyframe = -1;  ///< Pending tracks: keyframe where first seen.
  Eigen::Vector3d first_bearing = Eigen::Vector3d::UnitZ();  ///< Bearing in that keyframe.
  // Initialisation only: where the track was in the reference frame.
  bool has_reference = false;
  cv::Point2f reference_px;
  Eigen::Vector3d reference_bearing = Eigen::Vector3d::UnitZ();
};

struct FramePose {
  TimeNs t = 0;
  int keyframe = -1;
  Rigid3d keyframe_from_frame;
};

enum class State { kStart, kInitialising, kTracking, kLost };

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(mid), v.end());
  return v[mid];
}

}  // namespace

struct VisualOdometry::Impl {
  Impl(const Camera& camera_, const OdometryOptions& options_)
      : camera(camera_), options(options_), rng(options_.seed) {
    if (const std::string why = options.check(); !why.empty()) throw Error("odometry: " + why);
    factor = downscaleFactor(camera.width(), options);
    width = camera.width() / factor;
    height = camera.height() / factor;
    // Valid pixels: inside the model's field of view and max_incidence_deg.
    mask = cv::Mat::zeros(height, width, CV_8U);
    const double max_angle = std::min(options.max_incidence_deg * kDeg, camera.maxIncidenceAngle());
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        const auto b = camera.unproject(toFull(cv::Point2f(float(u), float(v))));
        if (b && std::acos(std::clamp(b->z(), -1.0, 1.0)) <= max_angle) mask.at<uchar>(v, u) = 255;
      }
    }
    const int border = static_cast<int>(std::ceil(options.border_px));
    if (border > 0) {
      cv::rectangle(mask, cv::Rect(0, 0, width, height), cv::Scalar(0), border);
      cv::erode(
          mask, mask,
          cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * border + 1, 2 * border + 1)));
    }
    // Pixels per radian near the optical axis, at the working resolution.
    const auto p0 = camera.project(Eigen::Vector3d(0, 0, 1));
    const auto p1 = camera.project(Eigen::Vector3d(std::sin(0.02), 0, std::cos(0.02)));
    focal_px = (p0 && p1) ? (*p1 - *p0).norm() / 0.02 / factor : 200.0 / factor;
    threshold_rad = options.ransac_threshold_px / focal_px;
    loop = std::make_unique<LoopCloser>(options);
  }

  Eigen::Vector2d toFull(const cv::Point2f& p) const {
    return Eigen::Vector2d((p.x + 0.5) * factor - 0.5, (p.y + 0.5) * factor - 0.5);
  }
  bool inMask(const cv::Point2f& p) const {
    const int u = static_cast<int>(std::lround(p.x)), v = static_cast<int>(std::lround(p.y));
    return u >= 0 && v >= 0 && u < width && v < height && mask.at<uchar>(v, u) != 0;
  }
  std::optional<Eigen::Vector3d> bearingOf(const cv::Point2f& p) const {
    return camera.unproject(toFull(p));
  }
  RansacOptions ransac() {
    RansacOptions r;
    r.threshold_rad = threshold_rad;
    r.max_iterations = options.ransac_max_iterations;
    r.seed = static_cast<std::uint32_t>(rng());
    return r;
  }

  // ---- tracking ------------------------------------------------------------

  void trackFeatures(const std::vector<cv::Mat>& pyramid) {
    StageTimer timer(stats.stage_seconds, "klt");
    if (tracks.empty() || previous_pyramid.empty()) return;
    std::vector<cv::Point2f> p0, p1, back;
    for (const Track& tr : tracks) p0.push_back(tr.px);
    std::vector<uchar> status, status_back;
    std::vector<float> err;
    const cv::Size win(options.klt_window_px, options.klt_window_px);
    const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.03);
    // Predict from the previous motion of the tracks' image positions: none
    // (constant position); the pyramid covers the motion.
    cv::calcOpticalFlowPyrLK(previous_pyramid, pyramid, p0, p1, status, err, win,
                             options.klt_levels, term);
    cv::calcOpticalFlowPyrLK(pyramid, previous_pyramid, p1, back, status_back, err, win,
                             options.klt_levels, term);
    std::vector<Track> kept;
    kept.reserve(tracks.size());
    const double fb2 = options.klt_max_fb_error_px * options.klt_max_fb_error_px;
    for (size_t i = 0; i < tracks.size(); ++i) {
      if (!status[i] || !status_back[i]) continue;
      const cv::Point2f d = back[i] - p0[i];
      if (d.dot(d) > fb2 || !inMask(p1[i])) continue;
      const auto b = bearingOf(p1[i]);
      if (!b) continue;
      Track tr = tracks[i];
      tr.px = p1[i];
      tr.bearing = *b;
      kept.push_back(tr);
    }
    tracks.swap(kept);
  }

  /// New FAST corners where tracks are sparse (grid cells, minimum distance).
  void detectFeatures(const cv::Mat& image, int keyframe) {
    StageTimer timer(stats.stage_seconds, "detect");
    if (static_cast<int>(tracks.size()) >= options.max_features) return;
    const double cell = options.min_feature_distance_px;
    const int occ_w = static_cast<int>(width / cell) + 1,
              occ_h = static_cast<int>(height / cell) + 1;
    std::vector<uchar> occupied(static_cast<size_t>(occ_w * occ_h), 0);
    const int cols = options.grid_cols, rows = options.grid_rows;
    std::vector<int> per_cell(static_cast<size_t>(cols * rows), 0);
    auto grid_index = [&](const cv::Point2f& p) {
      const int c = std::clamp(static_cast<int>(p.x * cols / width), 0, cols - 1);
      const int r = std::clamp(static_cast<int>(p.y * rows / height), 0, rows - 1);
      return r * cols + c;
    };
    auto mark = [&](const cv::Point2f& p) {
      const int cu = static_cast<int>(p.x / cell), cv_ = static_cast<int>(p.y / cell);
      for (int dv = -1; dv <= 1; ++dv) {
        for (int du = -1; du <= 1; ++du) {
          const int u = cu + du, v = cv_ + dv;
          if (u >= 0 && v >= 0 && u < occ_w && v < occ_h) occupied[size_t(v * occ_w + u)] = 1;
        }
      }
    };
    for (const Track& tr : tracks) {
      mark(tr.px);
      ++per_cell[size_t(grid_index(tr.px))];
    }
    std::vector<cv::KeyPoint> corners;
    cv::FAST(image, corners, static_cast<int>(options.fast_threshold), true);
    std::sort(corners.begin(), corners.end(), [](const cv::KeyPoint& a, const cv::KeyPoint& b) {
      if (a.response != b.response) return a.response > b.response;
      if (a.pt.y != b.pt.y) return a.pt.y < b.pt.y;
      return a.pt.x < b.pt.x;
    });
    const int cap = (options.max_features + cols * rows - 1) / (cols * rows) + 1;
    int count = static_cast<int>(tracks.size());
    for (const cv::KeyPoint& kp : corners) {
      if (count >= options.max_features) break;
      if (!inMask(kp.pt)) continue;
      const int cu = static_cast<int>(kp.pt.x / cell), cv_ = static_cast<int>(kp.pt.y / cell);
      if (occupied[size_t(cv_ * occ_w + cu)]) continue;
      const int g = grid_index(kp.pt);
      if (per_cell[size_t(g)] >= cap) continue;
      const auto b = bearingOf(kp.pt);
      if (!b) continue;
      Track tr;
      tr.id = next_track_id++;
      tr.px = kp.pt;
      tr.bearing = *b;
      tr.first_keyframe = keyframe;
      tr.first_bearing = *b;
      tracks.push_back(tr);
      mark(kp.pt);
      ++per_cell[size_t(g)];
      ++count;
    }
  }

  // ---- initialisation --------------------------------------------------------

  void startInitialisation(TimeNs t, const cv::Mat& image) {
    tracks.clear();
    detectFeatures(image, -1);
    for (Track& tr : tracks) {
      tr.has_reference = true;
      tr.reference_px = tr.px;
      tr.reference_bearing = tr.bearing;
    }
    reference_time = t;
    reference_image = image.clone();
    reference_count = static_cast<int>(tracks.size());
    state = State::kInitialising;
  }

  bool tryInitialise(TimeNs t, const cv::Mat& image) {
    StageTimer timer(stats.stage_seconds, "init");
    std::vector<size_t> idx;
    std::vector<double> moves;
    Bearings b_ref, b_cur;
    for (size_t i = 0; i < tracks.size(); ++i) {
      if (!tracks[i].has_reference) continue;
      idx.push_back(i);
      b_ref.push_back(tracks[i].reference_bearing);
      b_cur.push_back(tracks[i].bearing);
      const cv::Point2f d = tracks[i].px - tracks[i].reference_px;
      moves.push_back(std::sqrt(d.dot(d)));
    }
    if (static_cast<int>(idx.size()) < options.init_min_inliers ||
        static_cast<int>(idx.size()) < reference_count / 5) {
      startInitialisation(t, image);  // Too much lost: a fresh reference.
      return false;
    }
    // Not worth trying before the image has moved enough for the parallax wanted.
    if (median(moves) < 0.5 * options.init_min_parallax_deg * kDeg * focal_px) return false;
    const auto rel = estimateRelativePose(b_ref, b_cur, ransac());
    if (std::getenv("LOOKBOTH_VO_DEBUG"))
      std::fprintf(stderr, "init t=%lld: %zu tracks (ref %d), median move %.1f px, inliers %d\n",
                   static_cast<long long>(t), idx.size(), reference_count, median(moves),
                   rel ? rel->num_inliers : -1);
    if (!rel || rel->num_inliers < options.init_min_inliers) return false;
    const Rigid3d ref_from_cur = rel->cam1_from_cam2;
    std::vector<std::optional<Eigen::Vector3d>> points(idx.size());
    std::vector<double> angles, depths;
    const double min_angle = options.triangulation_min_angle_deg * kDeg;
    for (size_t j = 0; j < idx.size(); ++j) {
      if (!rel->inliers[j]) continue;
      auto p = triangulateMidpoint(Rigid3d::Identity(), b_ref[j], ref_from_cur, b_cur[j], 0.0);
      if (!p) continue;
      const Eigen::Vector3d ray_cur = *p - ref_from_cur.translation;
      const double angle =
          std::acos(std::clamp(p->normalized().dot(ray_cur.normalized()), -1.0, 1.0));
      angles.push_back(angle);
      if (angle < min_angle) continue;
      if (angularError(b_ref[j], *p) > threshold_rad ||
          angularError(b_cur[j], ref_from_cur.inverse() * *p) > threshold_rad)
        continue;
      points[j] = p;
      depths.push_back(p->norm());
    }
    if (std::getenv("LOOKBOTH_VO_DEBUG"))
      std::fprintf(stderr, "  median parallax %.2f deg, %zu triangulated\n", median(angles) / kDeg,
                   depths.size());
    if (median(angles) < options.init_min_parallax_deg * kDeg ||
        static_cast<int>(depths.size()) < options.init_min_inliers)
      return false;  // Pure rotation or too little parallax yet: wait.

    // Scale: median depth 1 for the first segment, the last segment's median
    // depth for later ones; placed at the last known pose.
    const double target_depth = segment_count == 0 ? 1.0 : last_median_depth;
    const double s = target_depth / median(depths);
    const Rigid3d world_from_ref = segment_count == 0 ? Rigid3d::Identity() : last_pose;
    Rigid3d ref_from_cur_scaled = ref_from_cur;
    ref_from_cur_scaled.translation *= s;

    const int segment = segment_count++;
    const int k0 = addKeyframe(reference_time, world_from_ref, segment);
    const int k1 = addKeyframe(t, world_from_ref * ref_from_cur_scaled, segment);
    for (size_t j = 0; j < idx.size(); ++j) {
      Track& tr = tracks[idx[j]];
      tr.has_reference = false;
      if (!points[j]) {
        tr.first_keyframe = k1;
        tr.first_bearing = tr.bearing;
        continue;
      }
      const int l = map.addLandmark(world_from_ref * (s * *points[j]), k0);
      map.observe(l, k0, tr.reference_bearing);
      map.observe(l, k1, tr.bearing);
      tr.landmark = l;
    }
    // Drop tracks without a landmark that are outliers of the geometry.
    std::vector<Track> kept;
    for (size_t j = 0; j < idx.size(); ++j) {
      if (rel->inliers[j]) kept.push_back(tracks[idx[j]]);
    }
    tracks.swap(kept);
    {
      StageTimer ba_timer(stats.stage_seconds, "local_ba");
      AdjustmentOptions ba = adjustment(options.local_iterations * 2);
      bundleAdjust(map, {k0, k1}, {k0}, ba);
    }
    dropInvalidTrackLandmarks();
    updateMedianDepth(k0);
    updateMedianDepth(k1);
    frame_poses.push_back({reference_time, k0, Rigid3d::Identity()});
    frame_poses.push_back({t, k1, Rigid3d::Identity()});
    finishKeyframe(k1, image);
    finishKeyframe(k0, reference_image);
    reference_image.release();
    last_pose = map.keyframes[k1].world_from_camera;
    velocity = Rigid3d::Identity();
    state = State::kTracking;
    stats.events.push_back("initialised segment " + std::to_string(segment) +
                           " at t=" + std::to_string(t) + " with " + std::to_string(depths.size()) +
                           " landmarks");
    return true;
  }

  // ---- map -------------------------------------------------------------------

  int addKeyframe(TimeNs t, const Rigid3d& world_from_camera, int segment) {
    Keyframe kf;
    kf.id = static_cast<int>(map.keyframes.size());
    kf.t = t;
    kf.segment = segment;
    kf.world_from_camera = world_from_camera;
    map.keyframes.push_back(kf);
    ++stats.keyframes;
    return kf.id;
  }

  AdjustmentOptions adjustment(int iterations) const {
    AdjustmentOptions a;
    a.focal_px = focal_px;
    a.huber_px = options.huber_px;
    a.iterations = iterations;
    a.threads = options.threads;
    a.outlier_px = 3 * options.ransac_threshold_px;
    return a;
  }

  void dropInvalidTrackLandmarks() {
    std::vector<Track> kept;
    kept.reserve(tracks.size());
    for (Track& tr : tracks) {
      if (tr.landmark >= 0 && !map.landmarks[size_t(tr.landmark)].valid) continue;
      kept.push_back(tr);
    }
    tracks.swap(kept);
  }

  void updateMedianDepth(int k) {
    Keyframe& kf = map.keyframes[size_t(k)];
    std::vector<double> d;
    for (int l : kf.landmarks) {
      if (map.landmarks[size_t(l)].valid)
        d.push_back(
            (map.landmarks[size_t(l)].p_in_world - kf.world_from_camera.translation).norm());
    }
    if (!d.empty()) kf.median_depth = median(d);
    last_median_depth = kf.median_depth;
  }

  /// Descriptors for loop closure and relocalisation, then the loop query.
  void finishKeyframe(int k, const cv::Mat& image) {
    Keyframe& kf = map.keyframes[size_t(k)];
    std::vector<cv::Point2f> pixels;
    std::vector<int> landmarks;
    const Rigid3d camera_from_world = kf.world_from_camera.inverse();
    for (int l : kf.landmarks) {
      const Landmark& lm = map.landmarks[size_t(l)];
      if (!lm.valid) continue;
      const auto px = camera.project(camera_from_world * lm.p_in_world);
      if (!px) continue;
      pixels.emplace_back(float((px->x() + 0.5) / factor - 0.5),
                          float((px->y() + 0.5) / factor - 0.5));
      landmarks.push_back(l);
    }
    {
      StageTimer timer(stats.stage_seconds, "describe");
      loop->describe(
          image, mask, pixels, landmarks, [this](const cv::Point2f& p) { return bearingOf(p); },
          kf);
    }
    last_keyframe = k;
    last_keyframe_tracked = 0;
    for (const Track& tr : tracks) last_keyframe_tracked += tr.landmark >= 0 ? 1 : 0;
    frames_since_keyframe = 0;
  }

  void createKeyframe(TimeNs t, const Rigid3d& world_from_camera, const cv::Mat& image) {
    int k;
    {
      StageTimer timer(stats.stage_seconds, "keyframe");
      k = addKeyframe(t, world_from_camera, map.keyframes[size_t(last_keyframe)].segment);
      const double min_angle = options.triangulation_min_angle_deg * kDeg;
      for (Track& tr : tracks) {
        if (tr.landmark >= 0) {
          map.observe(tr.landmark, k, tr.bearing);
          continue;
        }
        if (tr.first_keyframe < 0) {  // Detected between keyframes: anchored here.
          tr.first_keyframe = k;
          tr.first_bearing = tr.bearing;
          continue;
        }
        if (tr.first_keyframe < 0 ||
            map.keyframes[size_t(tr.first_keyframe)].segment != map.keyframes[size_t(k)].segment)
          continue;
        const Rigid3d& world_from_first =
            map.keyframes[size_t(tr.first_keyframe)].world_from_camera;
        const auto p = triangulateMidpoint(world_from_first, tr.first_bearing, world_from_camera,
                                           tr.bearing, min_angle);
        if (!p) continue;
        if (angularError(tr.first_bearing, world_from_first.inverse() * *p) > threshold_rad ||
            angularError(tr.bearing, world_from_camera.inverse() * *p) > threshold_rad)
          continue;
        const int l = map.addLandmark(*p, tr.first_keyframe);
        map.observe(l, tr.first_keyframe, tr.first_bearing);
        map.observe(l, k, tr.bearing);
        tr.landmark = l;
      }
    }
    detectFeatures(image, k);
    localAdjustment(k);
    updateMedianDepth(k);
    finishKeyframe(k, image);
    {
      StageTimer timer(stats.stage_seconds, "loop_detect");
      if (options.loop_closure) {
        if (auto closure = loop->detect(map, k, ransac())) {
          StageTimer correct_timer(stats.stage_seconds, "loop_correct");
          applyLoopClosure(*closure);
        }
      }
    }
    compactMap(k);
  }

  /// Keeps the map's memory growing only weakly with the keyframes: the
  /// fresh ORB features of a keyframe (only its own loop query uses them,
  /// and the vocabulary's training) are released once queried; a keyframe
  /// leaving the local window keeps only its valid landmarks and their
  /// descriptors (what loop verification, relocalisation and the global
  /// adjustment use).
  void compactMap(int k) {
    if (!options.loop_closure || loop->trained()) {
      for (; fresh_released < k + 1; ++fresh_released) {
        Keyframe& kf = map.keyframes[size_t(fresh_released)];
        kf.orb_descriptors.release();
        std::vector<Eigen::Vector3d>().swap(kf.orb_bearings);
      }
    }
    for (; compacted < k + 1 - options.local_window; ++compacted) {
      Keyframe& kf = map.keyframes[size_t(compacted)];
      auto valid = [this](int l) { return map.landmarks[size_t(l)].valid; };
      std::vector<int> landmarks;
      std::copy_if(kf.landmarks.begin(), kf.landmarks.end(), std::back_inserter(landmarks), valid);
      kf.landmarks.swap(landmarks);
      kf.landmarks.shrink_to_fit();
      cv::Mat descriptors;
      std::vector<int> descriptor_landmarks;
      for (size_t i = 0; i < kf.descriptor_landmarks.size(); ++i) {
        if (!valid(kf.descriptor_landmarks[i])) continue;
        descriptors.push_back(kf.descriptors.row(static_cast<int>(i)));
        descriptor_landmarks.push_back(kf.descriptor_landmarks[i]);
      }
      kf.descriptors = descriptors;
      kf.descriptor_landmarks.swap(descriptor_landmarks);
    }
  }

  void localAdjustment(int k) {
    StageTimer timer(stats.stage_seconds, "local_ba");
    std::set<int> window;
    const int segment = map.keyframes[size_t(k)].segment;
    for (int j = k; j >= 0 && static_cast<int>(window.size()) < options.local_window; --j) {
      if (map.keyframes[size_t(j)].segment == segment) window.insert(j);
    }
    std::set<int> fixed;
    // The gauge: the segment's first keyframe when in the window; otherwise
    // the keyframes outside the window that see its landmarks hold it.
    const int first = *window.begin();
    if (first == 0 || map.keyframes[size_t(first - 1)].segment != segment) fixed.insert(first);
    bundleAdjust(map, window, fixed, adjustment(options.local_iterations));
    dropInvalidTrackLandmarks();
  }

  /// The global bundle adjustment of a segment: one problem over all its
  /// keyframes within the observation budget, or windows (global_window).
  void globalAdjustment(const std::set<int>& ids, int gauge) {
    if (options.global_window > 0) {
      bundleAdjustWindowed(map, ids, gauge, options.global_window, options.global_sweeps,
                           adjustment(options.global_iterations), &global_report);
      return;
    }
    ObservationBudget budget;
    budget.max_observations = options.global_max_observations;
    budget.min_per_keyframe = options.global_min_observations_per_keyframe;
    bundleAdjustSampled(map, ids, gauge, budget, adjustment(options.global_iterations),
                        &global_report);
  }

  // ---- loop closure -------------------------------------------------------------

  void applyLoopClosure(const LoopClosure& closure) {
    const int k = closure.current_keyframe;
    const int segment_old = map.keyframes[size_t(closure.old_keyframe)].segment;
    const int segment_cur = map.keyframes[size_t(k)].segment;
    // Nodes: keyframes of both segments.
    std::map<int, Sim3d> nodes;
    std::set<int> fixed;
    int first_old = -1;
    for (const Keyframe& kf : map.keyframes) {
      if (kf.segment != segment_old && kf.segment != segment_cur) continue;
      Sim3d s(kf.world_from_camera);
      if (kf.segment == segment_cur && segment_cur != segment_old)
        s = closure.old_from_current * s;  // Bring the new segment over as a whole.
      nodes[kf.id] = s;
      if (kf.segment == segment_old && first_old < 0) first_old = kf.id;
    }
    fixed.insert(first_old);
    std::vector<PoseGraphEdge> edges;
    std::vector<int> ids;
    for (const auto& entry : nodes) ids.push_back(entry.first);
    for (size_t i = 0; i < ids.size(); ++i) {
      for (size_t j = i + 1; j < ids.size() && j <= i + 3; ++j) {
        const Keyframe& a = map.keyframes[size_t(ids[i])];
        const Keyframe& b = map.keyframes[size_t(ids[j])];
        if (a.segment != b.segment) continue;
        PoseGraphEdge e;
        e.from = a.id;
        e.to = b.id;
        e.from_from_to = Sim3d(a.world_from_camera.inverse() * b.world_from_camera);
        edges.push_back(e);
      }
    }
    PoseGraphEdge loop_edge;
    loop_edge.from = closure.old_keyframe;
    loop_edge.to = k;
    loop_edge.from_from_to =
        Sim3d(map.keyframes[size_t(closure.old_keyframe)].world_from_camera).inverse() *
        closure.old_from_current * Sim3d(map.keyframes[size_t(k)].world_from_camera);
    edges.push_back(loop_edge);
    // Translations in units of the scene depth, so that they weigh like the rotations.
    const double unit = std::max(map.keyframes[size_t(first_old)].median_depth, 1e-9);
    for (PoseGraphEdge& e : edges) e.from_from_to.translation /= unit;
    std::map<int, Sim3d> scaled;
    for (const auto& [id, s] : nodes) scaled[id] = Sim3d(s.scale, s.rotation, s.translation / unit);
    std::map<int, Sim3d> corrected = optimisePoseGraph(scaled, edges, fixed, 50, options.threads);
    for (auto& [id, s] : corrected) s.translation *= unit;

    // Move landmarks with their reference keyframe, frames with theirs.
    std::map<int, Sim3d> correction;  // new world from old world, per keyframe
    for (const auto& [id, s] : corrected) {
      correction[id] = s * Sim3d(map.keyframes[size_t(id)].world_from_camera).inverse();
    }
    for (Landmark& l : map.landmarks) {
      if (!l.valid) continue;
      auto it = correction.find(l.reference_keyframe);
      if (it != correction.end()) l.p_in_world = it->second * l.p_in_world;
    }
    for (FramePose& f : frame_poses) {
      auto it = corrected.find(f.keyframe);
      if (it != corrected.end()) f.keyframe_from_frame.translation *= it->second.scale;
    }
    for (const auto& [id, s] : corrected) {
      Keyframe& kf = map.keyframes[size_t(id)];
      kf.world_from_camera = Rigid3d(s.rotation, s.translation);
      kf.median_depth *= s.scale;
      kf.segment = segment_old;
    }
    // The current keyframe sees the verified old landmarks: the global
    // adjustment then holds both ends of the loop together.
    for (const auto& [landmark, bearing] : closure.observations) {
      if (map.landmarks[size_t(landmark)].valid) map.observe(landmark, k, bearing);
    }
    // Global adjustment of the joined segment.
    {
      StageTimer timer(stats.stage_seconds, "global_ba");
      std::set<int> all;
      for (const Keyframe& kf : map.keyframes) {
        if (kf.segment == segment_old) all.insert(kf.id);
      }
      globalAdjustment(all, first_old);
    }
    dropInvalidTrackLandmarks();
    last_pose = map.keyframes[size_t(k)].world_from_camera;
    ++stats.loop_closures;
    stats.loops.emplace_back(map.keyframes[size_t(k)].t,
                             map.keyframes[size_t(closure.old_keyframe)].t);
    stats.events.push_back(
        "loop closed: keyframe " + std::to_string(k) + " with keyframe " +
        std::to_string(closure.old_keyframe) + " (" + std::to_string(closure.initial_inliers) +
        " inliers of the ORB matches, " + std::to_string(closure.observations.size()) +
        " after guided matching, scale " + std::to_string(closure.old_from_current.scale) + ")");
  }

  // ---- per frame -------------------------------------------------------------

  bool trackPose(TimeNs t, const cv::Mat& image) {
    Bearings bearings;
    std::vector<Eigen::Vector3d> points;
    std::vector<size_t> idx;
    for (size_t i = 0; i < tracks.size(); ++i) {
      if (tracks[i].landmark < 0) continue;
      idx.push_back(i);
      bearings.push_back(tracks[i].bearing);
      points.push_back(map.landmarks[size_t(tracks[i].landmark)].p_in_world);
    }
    std::optional<AbsolutePoseResult> pose;
    {
      StageTimer timer(stats.stage_seconds, "pose");
      if (static_cast<int>(idx.size()) >= options.min_tracking_inliers)
        pose = estimateAbsolutePose(bearings, points, ransac());
    }
    if (!pose || pose->num_inliers < options.min_tracking_inliers) return false;
    // Outliers lose their track.
    std::vector<bool> drop(tracks.size(), false);
    for (size_t j = 0; j < idx.size(); ++j) drop[idx[j]] = !pose->inliers[j];
    std::vector<Track> kept;
    for (size_t i = 0; i < tracks.size(); ++i) {
      if (!drop[i]) kept.push_back(tracks[i]);
    }
    tracks.swap(kept);
    const Rigid3d world_from_camera = pose->world_from_camera;
    ++stats.tracked_frames;
    sum_inliers += pose->num_inliers;
    sum_tracked += static_cast<double>(tracks.size());
    velocity = last_pose.inverse() * world_from_camera;
    last_pose = world_from_camera;
    ++frames_since_keyframe;

    // Keyframe?
    const Keyframe& kf = map.keyframes[size_t(last_keyframe)];
    const Rigid3d kf_from_frame = kf.world_from_camera.inverse() * world_from_camera;
    const double moved = kf_from_frame.translation.norm() / std::max(kf.median_depth, 1e-9);
    const double turned = 2 * std::acos(std::min(1.0, std::abs(kf_from_frame.rotation.w())));
    int tracked = 0;
    for (const Track& tr : tracks) tracked += tr.landmark >= 0 ? 1 : 0;
    const bool need = moved > options.keyframe_translation_ratio ||
                      turned > options.keyframe_rotation_deg * kDeg ||
                      tracked < options.keyframe_tracked_ratio * last_keyframe_tracked ||
                      frames_since_keyframe >= options.max_frames_between_keyframes;
    if (need) {
      createKeyframe(t, world_from_camera, image);
      frame_poses.push_back({t, last_keyframe, Rigid3d::Identity()});
    } else {
      frame_poses.push_back({t, last_keyframe, kf_from_frame});
    }
    return true;
  }

  bool relocalise(TimeNs t, const cv::Mat& image) {
    StageTimer timer(stats.stage_seconds, "relocalise");
    const int k_end = static_cast<int>(map.keyframes.size());
    const int k_begin = std::max(0, k_end - options.relocalisation_keyframes);
    std::vector<int> candidates;
    for (int k = k_end - 1; k >= k_begin; --k) candidates.push_back(k);
    auto found = loop->relocalise(
        map, candidates, image, mask, [this](const cv::Point2f& p) { return bearingOf(p); },
        ransac(), options.min_tracking_inliers * 2);
    if (!found) return false;
    tracks.clear();
    for (const auto& [px, landmark] : found->inlier_features) {
      const auto b = bearingOf(px);
      if (!b) continue;
      Track tr;
      tr.id = next_track_id++;
      tr.px = px;
      tr.bearing = *b;
      tr.landmark = landmark;
      tracks.push_back(tr);
    }
    last_pose = found->world_from_camera;
    velocity = Rigid3d::Identity();
    ++stats.relocalisations;
    ++stats.tracked_frames;
    stats.events.push_back("relocalised at t=" + std::to_string(t) + " against keyframe " +
                           std::to_string(found->keyframe) + " (" +
                           std::to_string(found->inlier_features.size()) + " inliers)");
    createKeyframe(t, last_pose, image);
    frame_poses.push_back({t, last_keyframe, Rigid3d::Identity()});
    state = State::kTracking;
    return true;
  }

  bool process(TimeNs t, const cv::Mat& image) {
    ++stats.frames;
    std::vector<cv::Mat> pyramid;
    {
      StageTimer timer(stats.stage_seconds, "pyramid");
      cv::buildOpticalFlowPyramid(image, pyramid,
                                  cv::Size(options.klt_window_px, options.klt_window_px),
                                  options.klt_levels);
    }
    if (state != State::kLost) trackFeatures(pyramid);
    bool ok = false;
    switch (state) {
      case State::kStart:
        startInitialisation(t, image);
        break;
      case State::kInitialising:
        ok = tryInitialise(t, image);
        break;
      case State::kTracking:
        ok = trackPose(t, image);
        if (!ok) {
          ++stats.tracking_losses;
          stats.events.push_back("tracking lost at t=" + std::to_string(t) + " (" +
                                 std::to_string(tracks.size()) + " tracks)");
          state = State::kLost;
          lost_frames = 0;
        }
        break;
      case State::kLost:
        ok = relocalise(t, image);
        if (!ok && ++lost_frames > options.max_lost_frames) {
          stats.events.push_back("new segment from t=" + std::to_string(t));
          startInitialisation(t, image);
        }
        break;
    }
    if (state == State::kTracking && ok) detectFeaturesBetweenKeyframes(image);
    previous_pyramid = std::move(pyramid);
    return ok;
  }

  /// Keeps the track count up between keyframes when many were lost: new
  /// tracks wait for the next keyframe to be triangulated.
  void detectFeaturesBetweenKeyframes(const cv::Mat& image) {
    if (static_cast<int>(tracks.size()) >= options.max_features / 2) return;
    // New tracks are anchored at the last keyframe only if created there; here
    // they start pending without a keyframe and are anchored at the next one.
    const size_t before = tracks.size();
    detectFeatures(image, -1);
    for (size_t i = before; i < tracks.size(); ++i) tracks[i].first_keyframe = -1;
  }

  OdometryResult finish() {
    OdometryResult result;
    if (map.keyframes.size() >= 3) {
      StageTimer timer(stats.stage_seconds, "global_ba");
      std::map<int, std::set<int>> by_segment;
      for (const Keyframe& kf : map.keyframes) by_segment[kf.segment].insert(kf.id);
      for (const auto& [segment, ids] : by_segment) {
        if (ids.size() < 2) continue;
        globalAdjustment(ids, *ids.begin());
      }
    }
    for (const Keyframe& kf : map.keyframes) result.keyframes.append(kf.t, kf.world_from_camera);
    if (options.all_frames) {
      for (const FramePose& f : frame_poses) {
        result.trajectory.append(
            f.t, map.keyframes[size_t(f.keyframe)].world_from_camera * f.keyframe_from_frame);
      }
    } else {
      result.trajectory = result.keyframes;
    }
    stats.landmarks = 0;
    for (const Landmark& l : map.landmarks) {
      if (!l.valid) continue;
      ++stats.landmarks;
      MapPoint p;
      p.p_in_world = l.p_in_world;
      p.observations = static_cast<int>(l.observations.size());
      p.first_seen = map.keyframes[size_t(l.reference_keyframe)].t;
      result.landmarks.push_back(p);
    }
    stats.segments = segment_count;
    {
      std::set<int> segments;
      for (const Keyframe& kf : map.keyframes) segments.insert(kf.segment);
      stats.segments_at_end = static_cast<std::int64_t>(segments.size());
    }
    stats.map_bytes = static_cast<std::int64_t>(map.memoryBytes() + loop->memoryBytes());
    stats.global_problems = global_report.problems;
    stats.global_largest_observations = global_report.largest_residual_blocks;
    stats.global_largest_keyframes = global_report.largest_keyframes;
    if (stats.tracked_frames > 0) {
      stats.mean_inliers = sum_inliers / static_cast<double>(stats.tracked_frames);
      stats.mean_tracked_features = sum_tracked / static_cast<double>(stats.tracked_frames);
    }
    result.statistics = stats;
    return result;
  }

  const Camera camera;
  const OdometryOptions options;
  std::mt19937 rng;
  int factor = 1, width = 0, height = 0;
  cv::Mat mask;
  double focal_px = 200, threshold_rad = 0.01;

  State state = State::kStart;
  std::vector<Track> tracks;
  int next_track_id = 0;
  std::vector<cv::Mat> previous_pyramid;
  TimeNs reference_time = 0;
  cv::Mat reference_image;
  int reference_count = 0;

  Map map;
  std::unique_ptr<LoopCloser> loop;
  std::vector<FramePose> frame_poses;
  int last_keyframe = -1;
  int last_keyframe_tracked = 0;
  int frames_since_keyframe = 0;
  Rigid3d last_pose, velocity;
  double last_median_depth = 1.0;
  int segment_count = 0;
  int lost_frames = 0;
  int fresh_released = 0;          ///< Keyframes below this have released their fresh ORB features.
  int compacted = 0;               ///< Keyframes below this are compacted (compactMap).
  AdjustmentReport global_report;  ///< Sizes of the global adjustment's problems.

  OdometryStatistics stats;
  double sum_inliers = 0, sum_tracked = 0;
};

VisualOdometry::VisualOdometry(const Camera& camera, const OdometryOptions& options)
    : impl_(std::make_unique<Impl>(camera, options)) {}
VisualOdometry::~VisualOdometry() = default;

int VisualOdometry::downscaleFactor(int image_width, const OdometryOptions& options) {
  return std::max(1, static_cast<int>(std::lround(double(image_width) / options.working_width)));
}

cv::Mat VisualOdometry::prepareImage(const cv::Mat& image, int factor) {
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  } else {
    grey = image;
  }
  if (grey.depth() != CV_8U) grey.convertTo(grey, CV_8U);
  if (factor <= 1) return grey;
  cv::Mat small;
  cv::resize(grey, small, cv::Size(grey.cols / factor, grey.rows / factor), 0, 0, cv::INTER_AREA);
  return small;
}

bool VisualOdometry::processFrame(TimeNs t, const cv::Mat& working_image) {
  if (working_image.cols != impl_->width || working_image.rows != impl_->height)
    throw Error("odometry: frame at t=" + std::to_string(t) + " is " +
                std::to_string(working_image.cols) + "x" + std::to_string(working_image.rows) +
                " at the working resolution, expected " + std::to_string(impl_->width) + "x" +
                std::to_string(impl_->height));
  return impl_->process(t, working_image);
}

OdometryResult VisualOdometry::finish() { return impl_->finish(); }

const OdometryStatistics& VisualOdometry::statistics() const { return impl_->stats; }

double threadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::optional<AteResult> absoluteTrajectoryError(const Trajectory& estimate,
                                                 const Trajectory& ground_truth, TimeNs max_dt) {
  std::vector<Eigen::Vector3d> src, dst;
  for (const StampedPose& s : estimate.samples()) {
    const InterpolationResult gt = ground_truth.interpolate(s.t, 0);
    if (!gt.ok()) continue;
    if (std::min(std::abs(s.t - gt.t_before), std::abs(gt.t_after - s.t)) > max_dt) continue;
    src.push_back(s.world_from_body.translation);
    dst.push_back(gt.world_from_body.translation);
  }
  const auto aligned = alignSim3(src, dst);
  if (!aligned) return std::nullopt;
  AteResult r;
  r.matched = static_cast<int>(src.size());
  r.scale = aligned->dst_from_src.scale;
  double sum = 0;
  for (size_t i = 0; i < src.size(); ++i) {
    sum += (aligned->dst_from_src * src[i] - dst[i]).squaredNorm();
    if (i > 0) r.path_length += (dst[i] - dst[i - 1]).norm();
  }
  r.rmse = std::sqrt(sum / static_cast<double>(src.size()));
  return r;
}

}  // namespace lookboth::vo
