#include "loop_closure.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>

#include "lookboth/geometry/umeyama.h"

namespace lookboth::vo {
namespace {

constexpr int kPatch = 31;
constexpr int kPad = 32;
/// Matches of fresh ORB corners to landmarks: RANSAC bound x this.
constexpr double kLooseThreshold = 3.0;  // ORB skips keypoints closer than its patch to the border.
/// Guided matching of loops: the largest Hamming distance accepted [bits of 256].
constexpr int kMaxGuidedDistance = 64;
/// Loop verification: keyframes either side of the candidate whose landmarks
/// are matched by descriptor (ratio test), and those guided matching uses.
constexpr int kVerifyNeighbours = 4;
constexpr int kGuidedNeighbours = 10;

cv::Ptr<cv::ORB> makeOrb(int features) {
  return cv::ORB::create(features, 1.2f, 1, kPatch, 0, 2, cv::ORB::HARRIS_SCORE, kPatch, 12);
}

/// Orientation of a patch by its intensity centroid (as ORB) [deg].
float centroidAngle(const cv::Mat& padded, const cv::Point2f& p) {
  const int cx = static_cast<int>(std::lround(p.x)), cy = static_cast<int>(std::lround(p.y));
  const int r = kPatch / 2;
  double m10 = 0, m01 = 0;
  for (int dv = -r; dv <= r; ++dv) {
    const uchar* row = padded.ptr<uchar>(cy + dv);
    for (int du = -r; du <= r; ++du) {
      if (du * du + dv * dv > r * r) continue;
      const double value = row[cx + du];
      m10 += du * value;
      m01 += dv * value;
    }
  }
  return cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
}

/// ORB corners, oriented and described exactly as the landmarks are (so
/// that both kinds of descriptors match).
void detectAndDescribe(const cv::Mat& padded, const cv::Mat& padded_mask, int features,
                       std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) {
  const cv::Ptr<cv::ORB> orb = makeOrb(features);
  orb->detect(padded, keypoints, padded_mask);
  for (cv::KeyPoint& kp : keypoints) {
    kp.angle = centroidAngle(padded, kp.pt);
    kp.size = float(kPatch);
    kp.octave = 0;
  }
  orb->compute(padded, keypoints, descriptors);
}

int popcount256(const uchar* a, const uchar* b) {
  int d = 0;
  for (int i = 0; i < 32; i += 8) {
    std::uint64_t x, y;
    std::memcpy(&x, a + i, 8);
    std::memcpy(&y, b + i, 8);
    d += __builtin_popcountll(x ^ y);
  }
  return d;
}

/// Nearest row of `words` for every row of `descriptors`.
std::vector<int> nearestWords(const cv::Mat& descriptors, const cv::Mat& words) {
  std::vector<int> out(static_cast<size_t>(descriptors.rows), 0);
  for (int i = 0; i < descriptors.rows; ++i) {
    int best = 1 << 30;
    for (int w = 0; w < words.rows; ++w) {
      const int d = popcount256(descriptors.ptr<uchar>(i), words.ptr<uchar>(w));
      if (d < best) {
        best = d;
        out[size_t(i)] = w;
      }
    }
  }
  return out;
}

/// Ratio-test matches from `query` rows to `train` rows.
std::vector<std::pair<int, int>> matchDescriptors(const cv::Mat& query, const cv::Mat& train,
                                                  double ratio = 0.8, int max_distance = 64) {
  std::vector<std::pair<int, int>> out;
  if (query.empty() || train.rows < 2) return out;
  for (int i = 0; i < query.rows; ++i) {
    int best = 1 << 30, second = 1 << 30, best_j = -1;
    for (int j = 0; j < train.rows; ++j) {
      const int d = popcount256(query.ptr<uchar>(i), train.ptr<uchar>(j));
      if (d < best) {
        second = best;
        best = d;
        best_j = j;
      } else if (d < second) {
        second = d;
      }
    }
    if (best <= max_distance && best < ratio * second) out.emplace_back(i, best_j);
  }
  return out;
}

}  // namespace

LoopCloser::LoopCloser(const OdometryOptions& options) : options_(options) {}

void LoopCloser::describe(const cv::Mat& image, const cv::Mat& mask,
                          const std::vector<cv::Point2f>& pixels, const std::vector<int>& landmarks,
                          const BearingOf& bearing_of, Keyframe& keyframe) const {
  cv::Mat padded, padded_mask;
  cv::copyMakeBorder(image, padded, kPad, kPad, kPad, kPad, cv::BORDER_REFLECT_101);
  cv::copyMakeBorder(mask, padded_mask, kPad, kPad, kPad, kPad, cv::BORDER_CONSTANT, cv::Scalar(0));
  {
    std::vector<cv::KeyPoint> fresh;
    cv::Mat fresh_descriptors;
    detectAndDescribe(padded, padded_mask, options_.loop_features, fresh, fresh_descriptors);
    keyframe.orb_bearings.clear();
    keyframe.orb_descriptors = cv::Mat();
    for (size_t i = 0; i < fresh.size(); ++i) {
      const auto b = bearing_of(fresh[i].pt - cv::Point2f(kPad, kPad));
      if (!b) continue;
      keyframe.orb_bearings.push_back(*b);
      keyframe.orb_descriptors.push_back(fresh_descriptors.row(static_cast<int>(i)));
    }
  }
  std::vector<cv::KeyPoint> keypoints;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const cv::Point2f p(pixels[i].x + kPad, pixels[i].y + kPad);
    if (p.x < kPad / 2 || p.y < kPad / 2 || p.x >= padded.cols - kPad / 2 ||
        p.y >= padded.rows - kPad / 2)
      continue;
    keypoints.emplace_back(p, float(kPatch), centroidAngle(padded, p), 0.f, 0, static_cast<int>(i));
  }
  cv::Mat descriptors;
  if (!keypoints.empty()) makeOrb(1)->compute(padded, keypoints, descriptors);
  keyframe.descriptors = descriptors;
  keyframe.descriptor_landmarks.clear();
  for (const cv::KeyPoint& kp : keypoints)
    keyframe.descriptor_landmarks.push_back(landmarks[size_t(kp.class_id)]);
}

void LoopCloser::train(const Map& map, int up_to) {
  std::vector<const uchar*> rows;
  for (int k = 0; k <= up_to; ++k) {
    const cv::Mat& d = map.keyframes[size_t(k)].orb_descriptors;
    for (int i = 0; i < d.rows; ++i) rows.push_back(d.ptr<uchar>(i));
  }
  const int words = std::min<int>(options_.vocabulary_words, static_cast<int>(rows.size()) / 4);
  if (words < 8) return;
  std::mt19937 rng(options_.seed);
  std::vector<size_t> order(rows.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  cv::Mat centres(words, 32, CV_8U);
  for (int w = 0; w < words; ++w) std::memcpy(centres.ptr<uchar>(w), rows[order[size_t(w)]], 32);
  cv::Mat all(static_cast<int>(rows.size()), 32, CV_8U);
  for (size_t i = 0; i < rows.size(); ++i) std::memcpy(all.ptr<uchar>(int(i)), rows[i], 32);
  for (int iteration = 0; iteration < 5; ++iteration) {
    const std::vector<int> assign = nearestWords(all, centres);
    std::vector<std::array<int, 256>> ones(static_cast<size_t>(words));
    std::vector<int> count(size_t(words), 0);
    for (auto& o : ones) o.fill(0);
    for (int i = 0; i < all.rows; ++i) {
      const int w = assign[size_t(i)];
      ++count[size_t(w)];
      const uchar* d = all.ptr<uchar>(i);
      for (int bit = 0; bit < 256; ++bit)
        ones[size_t(w)][size_t(bit)] += (d[bit / 8] >> (bit % 8)) & 1;
    }
    for (int w = 0; w < words; ++w) {
      if (count[size_t(w)] == 0) continue;  // Keeps its seed.
      uchar* c = centres.ptr<uchar>(w);
      std::memset(c, 0, 32);
      for (int bit = 0; bit < 256; ++bit) {
        if (2 * ones[size_t(w)][size_t(bit)] > count[size_t(w)])
          c[bit / 8] |= uchar(1 << (bit % 8));
      }
    }
  }
  vocabulary_ = centres;
  // Inverse document frequency over the training keyframes.
  std::vector<int> documents(size_t(words), 0);
  for (int k = 0; k <= up_to; ++k) {
    std::set<int> seen;
    for (int w : nearestWords(map.keyframes[size_t(k)].orb_descriptors, vocabulary_))
      seen.insert(w);
    for (int w : seen) ++documents[size_t(w)];
  }
  idf_.assign(size_t(words), 0);
  for (int w = 0; w < words; ++w)
    idf_[size_t(w)] = std::log(double(up_to + 1) / double(1 + documents[size_t(w)])) + 1e-3;
  inverted_.assign(size_t(words), {});
  trained_ = true;
  for (int k = 0; k <= up_to; ++k) insert(k, wordsOf(map.keyframes[size_t(k)].orb_descriptors));
}

std::map<int, double> LoopCloser::wordsOf(const cv::Mat& descriptors) const {
  std::map<int, double> v;
  if (descriptors.empty()) return v;
  for (int w : nearestWords(descriptors, vocabulary_)) v[w] += idf_[size_t(w)];
  double sum = 0;
  for (const auto& [w, x] : v) sum += x;
  if (sum > 0) {
    for (auto& [w, x] : v) x /= sum;
  }
  return v;
}

void LoopCloser::insert(int k, const std::map<int, double>& words) {
  for (const auto& [w, x] : words) inverted_[size_t(w)].emplace_back(k, x);
}

std::size_t LoopCloser::memoryBytes() const {
  std::size_t bytes =
      vocabulary_.total() * vocabulary_.elemSize() + idf_.capacity() * sizeof(double);
  for (const auto& postings : inverted_)
    bytes += sizeof(postings) + postings.capacity() * sizeof(std::pair<int, double>);
  return bytes;
}

std::optional<LoopClosure> LoopCloser::detect(const Map& map, int k, const RansacOptions& ransac) {
  if (!trained_) {
    if (k + 1 >= options_.vocabulary_training_keyframes) train(map, k);
    return std::nullopt;
  }
  const std::map<int, double> words = wordsOf(map.keyframes[size_t(k)].orb_descriptors);
  std::optional<LoopClosure> found;
  if (k - last_closure_ >= 10) {
    // Score (L1 overlap of the normalised word vectors) of every older keyframe.
    std::map<int, double> score;
    for (const auto& [w, x] : words) {
      for (const auto& [other, y] : inverted_[size_t(w)]) {
        if (other <= k - options_.loop_min_keyframe_gap) score[other] += std::min(x, y);
      }
    }
    std::vector<std::pair<double, int>> ranked;
    for (const auto& [other, s] : score) ranked.emplace_back(-s, other);
    std::sort(ranked.begin(), ranked.end());
    for (size_t i = 0; i < ranked.size() && static_cast<int>(i) < options_.loop_candidates; ++i) {
      found = verify(map, k, ranked[i].second, ransac);
      if (std::getenv("LOOKBOTH_VO_DEBUG"))
        std::fprintf(stderr, "loop query kf %d: candidate %d score %.3f -> %s\n", k,
                     ranked[i].second, -ranked[i].first, found ? "closed" : "rejected");
      if (found) {
        last_closure_ = k;
        break;
      }
    }
  }
  insert(k, words);
  return found;
}

std::optional<LoopClosure> LoopCloser::verify(const Map& map, int k, int candidate,
                                              const RansacOptions& ransac) const {
  // 2D-3D: the current keyframe's fresh ORB features against the landmarks of
  // the candidate and its neighbours (same segment, old enough).
  const Keyframe& current = map.keyframes[size_t(k)];
  std::vector<int> old_landmarks;
  cv::Mat old_descriptors;
  std::set<int> seen;
  const std::set<int> current_set(current.landmarks.begin(), current.landmarks.end());
  const int segment = map.keyframes[size_t(candidate)].segment;
  // The candidate's neighbours within kVerifyNeighbours give the ratio-test
  // matches (rows [0, near) of old_descriptors); guided matching also uses
  // the landmarks of those up to kGuidedNeighbours away.
  int near = 0;
  for (const int reach : {kVerifyNeighbours, kGuidedNeighbours}) {
    for (int j = std::max(0, candidate - reach);
         j <= std::min<int>(candidate + reach, static_cast<int>(map.keyframes.size()) - 1); ++j) {
      const Keyframe& kf = map.keyframes[size_t(j)];
      if (kf.segment != segment || j > k - options_.loop_min_keyframe_gap) continue;
      for (int i = 0; i < kf.descriptors.rows; ++i) {
        const int l = kf.descriptor_landmarks[size_t(i)];
        if (!map.landmarks[size_t(l)].valid || current_set.count(l) || !seen.insert(l).second)
          continue;
        old_landmarks.push_back(l);
        old_descriptors.push_back(kf.descriptors.row(i));
      }
    }
    if (reach == kVerifyNeighbours) near = old_descriptors.rows;
  }
  if (near < options_.loop_min_inliers) return std::nullopt;
  const auto matches = matchDescriptors(current.orb_descriptors, old_descriptors.rowRange(0, near));
  if (std::getenv("LOOKBOTH_VO_DEBUG"))
    std::fprintf(stderr, "  verify %d-%d: %d vs %d descriptors, %zu matches\n", k, candidate,
                 current.orb_descriptors.rows, old_descriptors.rows, matches.size());
  // A first pose from the ratio-test matches needs fewer inliers than the
  // loop itself: guided matching then gathers the rest (or does not).
  const int min_initial = std::max(8, (options_.loop_min_inliers * 3) / 5);
  if (static_cast<int>(matches.size()) < min_initial) return std::nullopt;
  Bearings bearings;
  std::vector<Eigen::Vector3d> points;
  for (const auto& [qi, ti] : matches) {
    bearings.push_back(current.orb_bearings[size_t(qi)]);
    points.push_back(map.landmarks[size_t(old_landmarks[size_t(ti)])].p_in_world);
  }
  // Fresh ORB corners lie a few pixels from the tracked corners the landmarks
  // were made of: a wider bound than for tracking.
  RansacOptions loose = ransac;
  loose.threshold_rad *= kLooseThreshold;
  const auto initial = estimateAbsolutePose(bearings, points, loose);
  if (std::getenv("LOOKBOTH_VO_DEBUG"))
    std::fprintf(stderr, "  p3p inliers %d\n", initial ? initial->num_inliers : 0);
  if (!initial || initial->num_inliers < min_initial) return std::nullopt;

  // Guided matching: every landmark of the candidate's neighbourhood,
  // projected with the first pose, is matched to the nearest-in-descriptor
  // feature of the current keyframe within the loose bound of its predicted
  // bearing. Features: the fresh ORB corners and the keyframe's own landmark
  // observations (tracked FAST corners, the kind the old landmarks were made
  // of: the same corner seen again is found there more often).
  Bearings feature_bearings = current.orb_bearings;
  cv::Mat feature_descriptors = current.orb_descriptors.clone();
  for (int i = 0; i < current.descriptors.rows; ++i) {
    const Landmark& l = map.landmarks[size_t(current.descriptor_landmarks[size_t(i)])];
    for (const Observation& o : l.observations) {
      if (o.keyframe != k) continue;
      feature_bearings.push_back(o.bearing);
      feature_descriptors.push_back(current.descriptors.row(i));
      break;
    }
  }
  std::vector<std::pair<int, int>> guided;  // (feature, index into old_landmarks)
  {
    const Rigid3d camera_from_world = initial->world_from_camera.inverse();
    const double cos_radius = std::cos(loose.threshold_rad);
    std::vector<int> best_distance(feature_bearings.size(), kMaxGuidedDistance + 1);
    std::vector<int> best_landmark(feature_bearings.size(), -1);
    for (size_t j = 0; j < old_landmarks.size(); ++j) {
      const Eigen::Vector3d predicted =
          (camera_from_world * map.landmarks[size_t(old_landmarks[j])].p_in_world).normalized();
      int best = kMaxGuidedDistance + 1, best_i = -1;
      for (size_t i = 0; i < feature_bearings.size(); ++i) {
        if (feature_bearings[i].dot(predicted) < cos_radius) continue;
        const int d = popcount256(feature_descriptors.ptr<uchar>(static_cast<int>(i)),
                                  old_descriptors.ptr<uchar>(static_cast<int>(j)));
        if (d < best) {
          best = d;
          best_i = static_cast<int>(i);
        }
      }
      if (best_i >= 0 && best < best_distance[size_t(best_i)]) {
        best_distance[size_t(best_i)] = best;
        best_landmark[size_t(best_i)] = static_cast<int>(j);
      }
    }
    for (size_t i = 0; i < best_landmark.size(); ++i) {
      if (best_landmark[i] >= 0) guided.emplace_back(static_cast<int>(i), best_landmark[i]);
    }
  }
  bearings.clear();
  points.clear();
  for (const auto& [qi, ti] : guided) {
    bearings.push_back(feature_bearings[size_t(qi)]);
    points.push_back(map.landmarks[size_t(old_landmarks[size_t(ti)])].p_in_world);
  }
  const auto pose = estimateAbsolutePose(bearings, points, loose);
  if (std::getenv("LOOKBOTH_VO_DEBUG"))
    std::fprintf(stderr, "  guided: %zu matches, %d inliers\n", guided.size(),
                 pose ? pose->num_inliers : 0);
  if (!pose || pose->num_inliers < options_.loop_min_inliers) return std::nullopt;
  const auto& matches_final = guided;

  // Scale between the maps: depths of the same ceiling seen from the same
  // place, in old units (verified landmarks from the verified pose) over
  // current units (the current keyframe's median depth).
  std::vector<double> depths;
  LoopClosure closure;
  for (size_t i = 0; i < matches_final.size(); ++i) {
    if (!pose->inliers[i]) continue;
    depths.push_back((points[i] - pose->world_from_camera.translation).norm());
    closure.observations.emplace_back(old_landmarks[size_t(matches_final[i].second)], bearings[i]);
  }
  closure.initial_inliers = initial->num_inliers;
  std::nth_element(depths.begin(), depths.begin() + static_cast<long>(depths.size() / 2),
                   depths.end());
  const double scale = depths[depths.size() / 2] / std::max(current.median_depth, 1e-12);
  if (!(scale > 0.2 && scale < 5)) return std::nullopt;
  closure.current_keyframe = k;
  closure.old_keyframe = candidate;
  // old_from_current = old_world_from_camera * scale * camera_from_current_world.
  closure.old_from_current = Sim3d(pose->world_from_camera) *
                             Sim3d(scale, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()) *
                             Sim3d(current.world_from_camera.inverse());
  return closure;
}

std::optional<Relocalisation> LoopCloser::relocalise(
    const Map& map, const std::vector<int>& keyframes, const cv::Mat& image, const cv::Mat& mask,
    const std::function<std::optional<Eigen::Vector3d>(const cv::Point2f&)>& bearing_of,
    const RansacOptions& ransac, int min_inliers) const {
  cv::Mat padded, padded_mask;
  cv::copyMakeBorder(image, padded, kPad, kPad, kPad, kPad, cv::BORDER_REFLECT_101);
  cv::copyMakeBorder(mask, padded_mask, kPad, kPad, kPad, kPad, cv::BORDER_CONSTANT, cv::Scalar(0));
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  detectAndDescribe(padded, padded_mask, 2 * options_.loop_features, keypoints, descriptors);
  if (keypoints.size() < size_t(min_inliers)) return std::nullopt;
  std::vector<int> landmarks;
  std::vector<int> source;
  cv::Mat map_descriptors;
  std::set<int> seen;
  for (int k : keyframes) {
    const Keyframe& kf = map.keyframes[size_t(k)];
    for (int i = 0; i < kf.descriptors.rows; ++i) {
      const int l = kf.descriptor_landmarks[size_t(i)];
      if (!map.landmarks[size_t(l)].valid || !seen.insert(l).second) continue;
      landmarks.push_back(l);
      source.push_back(k);
      map_descriptors.push_back(kf.descriptors.row(i));
    }
  }
  const auto matches = matchDescriptors(descriptors, map_descriptors);
  if (static_cast<int>(matches.size()) < min_inliers) return std::nullopt;
  Bearings bearings;
  std::vector<Eigen::Vector3d> points;
  std::vector<std::pair<cv::Point2f, int>> features;
  for (const auto& [qi, ti] : matches) {
    const cv::Point2f px = keypoints[size_t(qi)].pt - cv::Point2f(kPad, kPad);
    const auto b = bearing_of(px);
    if (!b) continue;
    bearings.push_back(*b);
    points.push_back(map.landmarks[size_t(landmarks[size_t(ti)])].p_in_world);
    features.emplace_back(px, landmarks[size_t(ti)]);
  }
  RansacOptions loose = ransac;
  loose.threshold_rad *= kLooseThreshold;
  const auto pose = estimateAbsolutePose(bearings, points, loose);
  if (!pose || pose->num_inliers < min_inliers) return std::nullopt;
  Relocalisation r;
  r.world_from_camera = pose->world_from_camera;
  r.keyframe = source[size_t(matches.front().second)];
  for (size_t i = 0; i < features.size(); ++i) {
    if (pose->inliers[i]) r.inlier_features.push_back(features[i]);
  }
  return r;
}

}  // namespace lookboth::vo
