// Place recognition (ORB words, inverted index), geometric verification by a
// 3D-3D similarity, and relocalisation against recent keyframes (private).
//
// Descriptors are ORB at the keyframe's landmark observations, oriented by
// the intensity centroid: a place seen again with the upward view rotated
// about the optical axis (the robot driving the other way) gives the same
// descriptors. The vocabulary is a flat k-majority clustering of the
// descriptors of the first keyframes (Debian has no DBoW2).
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <vector>

#include "lookboth/geometry/sim3.h"
#include "lookboth/vo/bearing_geometry.h"
#include "lookboth/vo/options.h"
#include "map.h"

namespace lookboth::vo {

struct LoopClosure {
  int current_keyframe = -1;
  int old_keyframe = -1;
  /// Maps the current (drifted) map coordinates onto the old keyframe's.
  Sim3d old_from_current;
  /// Verified matches: old landmarks seen in the current keyframe, with their bearings there.
  std::vector<std::pair<int, Eigen::Vector3d>> observations;
  /// Inliers of the first pose (ratio-test ORB matches), before guided
  /// matching gathered `observations` (its inliers) with that pose.
  int initial_inliers = 0;
};

struct Relocalisation {
  int keyframe = -1;
  Rigid3d world_from_camera;
  std::vector<std::pair<cv::Point2f, int>> inlier_features;  ///< Working pixel, landmark.
};

class LoopCloser {
 public:
  explicit LoopCloser(const OdometryOptions& options);

  /// ORB descriptors of a keyframe's landmarks at the given working pixels.
  using BearingOf = std::function<std::optional<Eigen::Vector3d>(const cv::Point2f&)>;

  /// ORB descriptors of a keyframe's landmarks at the given working pixels,
  /// and fresh ORB features inside `mask`.
  void describe(const cv::Mat& image, const cv::Mat& mask, const std::vector<cv::Point2f>& pixels,
                const std::vector<int>& landmarks, const BearingOf& bearing_of,
                Keyframe& keyframe) const;

  /// Queries the database with keyframe k (described), verifies the best
  /// candidates, then adds k to the database.
  std::optional<LoopClosure> detect(const Map& map, int k, const RansacOptions& ransac);

  /// True once the vocabulary is trained: from then on a keyframe's fresh
  /// ORB features are not needed after its own query (detect()).
  bool trained() const { return trained_; }

  /// Approximate heap bytes held (vocabulary and inverted index).
  std::size_t memoryBytes() const;

  /// Pose of a frame from ORB matches against the landmarks of `keyframes`.
  std::optional<Relocalisation> relocalise(
      const Map& map, const std::vector<int>& keyframes, const cv::Mat& image, const cv::Mat& mask,
      const std::function<std::optional<Eigen::Vector3d>(const cv::Point2f&)>& bearing_of,
      const RansacOptions& ransac, int min_inliers) const;

 private:
  void train(const Map& map, int up_to);
  std::map<int, double> wordsOf(const cv::Mat& descriptors) const;
  void insert(int k, const std::map<int, double>& words);
  std::optional<LoopClosure> verify(const Map& map, int k, int candidate,
                                    const RansacOptions& ransac) const;

  OdometryOptions options_;
  bool trained_ = false;
  cv::Mat vocabulary_;                                         ///< One ORB descriptor per word.
  std::vector<double> idf_;                                    ///< Per word.
  std::vector<std::vector<std::pair<int, double>>> inverted_;  ///< Word -> (keyframe, weight).
  int last_closure_ = -1000000;
};

}  // namespace lookboth::vo
