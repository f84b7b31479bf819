// The map of the odometry (private): keyframes, landmarks, observations, and
// the adjustments that work on it.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <map>
#include <opencv2/core.hpp>
#include <set>
#include <vector>

#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/sim3.h"
#include "lookboth/geometry/time.h"

namespace lookboth::vo {

struct Observation {
  int keyframe = -1;
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();  ///< Unit, in the keyframe's camera frame.
};

struct Landmark {
  Eigen::Vector3d p_in_world = Eigen::Vector3d::Zero();
  std::vector<Observation> observations;
  int reference_keyframe = -1;  ///< The first keyframe that saw it (moves it in a correction).
  bool valid = true;
};

struct Keyframe {
  int id = -1;
  TimeNs t = 0;
  int segment = 0;
  Rigid3d world_from_camera;
  std::vector<int> landmarks;  ///< Landmarks observed (valid or not: check the landmark).
  double median_depth = 1.0;   ///< Of its landmarks [map units].
  // Loop closure and relocalisation: ORB descriptors of its landmark observations.
  cv::Mat descriptors;  ///< One row per entry of descriptor_landmarks.
  std::vector<int> descriptor_landmarks;
  // ORB features detected afresh in the keyframe (for place recognition and
  // the 2D-3D verification of loops): descriptors and their bearings.
  // Released once the keyframe's own loop query is done (and the vocabulary
  // trained): the odometry's compactMap.
  cv::Mat orb_descriptors;
  std::vector<Eigen::Vector3d> orb_bearings;
};

struct Map {
  std::vector<Keyframe> keyframes;  ///< Indexed by id.
  std::vector<Landmark> landmarks;  ///< Indexed by id.

  int addLandmark(const Eigen::Vector3d& p, int reference_keyframe) {
    Landmark l;
    l.p_in_world = p;
    l.reference_keyframe = reference_keyframe;
    landmarks.push_back(l);
    return static_cast<int>(landmarks.size()) - 1;
  }
  /// Adds the observation to both the landmark and the keyframe (once).
  void observe(int landmark, int keyframe, const Eigen::Vector3d& bearing) {
    Landmark& l = landmarks[landmark];
    for (const Observation& o : l.observations) {
      if (o.keyframe == keyframe) return;
    }
    l.observations.push_back({keyframe, bearing});
    keyframes[keyframe].landmarks.push_back(landmark);
  }

  /// Approximate heap bytes held by the map (the capacity of its containers).
  std::size_t memoryBytes() const {
    std::size_t bytes =
        keyframes.capacity() * sizeof(Keyframe) + landmarks.capacity() * sizeof(Landmark);
    for (const Keyframe& kf : keyframes) {
      bytes += kf.landmarks.capacity() * sizeof(int) +
               kf.descriptor_landmarks.capacity() * sizeof(int) +
               kf.descriptors.total() * kf.descriptors.elemSize() +
               kf.orb_descriptors.total() * kf.orb_descriptors.elemSize() +
               kf.orb_bearings.capacity() * sizeof(Eigen::Vector3d);
    }
    for (const Landmark& l : landmarks) bytes += l.observations.capacity() * sizeof(Observation);
    return bytes;
  }
};

struct AdjustmentOptions {
  double focal_px = 200;  ///< Pixels per radian: residuals are in pixels.
  double huber_px = 1.5;
  int iterations = 10;
  int threads = 1;
  double outlier_px = 6;  ///< Observations worse than this after the solve are removed.
  /// Solve with the Schur complement applied implicitly (conjugate gradients,
  /// Schur-Jacobi preconditioner) instead of factorising it: its memory does
  /// not grow with the keyframes' covisibility.
  bool implicit_schur = false;
};

/// Which observations of the landmarks take part.
enum class ObservationScope {
  kAll,                     ///< All, and all are checked for outliers.
  kCheckVariableKeyframes,  ///< All; only those of `variable` keyframes are checked.
  kVariableKeyframes,       ///< Only those of `variable` keyframes (the others
                            ///< neither hold the landmarks nor are checked).
};

/// The size of the problems solved (what their memory grows with).
struct AdjustmentReport {
  int problems = 0;                 ///< Ceres problems solved.
  int largest_residual_blocks = 0;  ///< Residual blocks (observations) of the largest.
  int largest_keyframes = 0;        ///< Keyframes (variable or held) of the largest.
};

/// Bundle adjustment of the keyframes `variable` and their landmarks; the
/// other keyframes that see those landmarks stay fixed, as do the keyframes
/// in `fixed` (the gauge). Removes outlier observations afterwards. Returns
/// the number of observations removed; `report`, if given, is updated with
/// the size of the problem. With `only_landmarks`, only those of the
/// landmarks take part (and only their observations are checked).
int bundleAdjust(Map& map, const std::set<int>& variable, const std::set<int>& fixed,
                 const AdjustmentOptions& options, ObservationScope scope = ObservationScope::kAll,
                 AdjustmentReport* report = nullptr, const std::set<int>* only_landmarks = nullptr);

/// Bundle adjustment of the keyframes `ids` with `gauge` (their first) fixed,
/// in bounded memory: when there are more than `window` keyframes (and
/// `window` > 0),
///  1. a coarse adjustment of at most `window` keyframes evenly spread over
///     `ids` (their own observations only) takes out the long-wavelength
///     errors, and the keyframes between them follow by interpolating the
///     correction (their landmarks with their reference keyframe);
///  2. `sweeps` passes over overlapping windows of `window` consecutive
///     keyframes (in id order, stride window / 2), each adjusted with
///     bundleAdjust while the keyframes around it stay fixed.
/// Otherwise one bundleAdjust over all. Returns the number of observations
/// removed; `report`, if given, is updated with the size of each problem.
int bundleAdjustWindowed(Map& map, const std::set<int>& ids, int gauge, int window, int sweeps,
                         const AdjustmentOptions& options, AdjustmentReport* report = nullptr);

/// A bound on the size of the global adjustment's problem.
struct ObservationBudget {
  int max_observations = 0;  ///< Residual blocks of the problem; 0 = no bound.
  int min_per_keyframe = 0;  ///< ... but at least this many observations per keyframe.
};

/// Global bundle adjustment of the keyframes `ids` (`gauge` fixed) as one
/// problem over all keyframes with at most `budget.max_observations`
/// observations: when their landmarks hold more, a subset of landmarks is
/// taken (longest tracks first) so that every keyframe keeps about
/// max_observations / ids.size() observations (at least
/// `budget.min_per_keyframe`), solved with the Schur complement applied
/// implicitly (AdjustmentOptions::implicit_schur); the landmarks left out
/// then follow the correction of their reference keyframe. Within the budget, the same as
/// bundleAdjust(map, ids, {gauge}). Returns the observations removed.
int bundleAdjustSampled(Map& map, const std::set<int>& ids, int gauge,
                        const ObservationBudget& budget, const AdjustmentOptions& options,
                        AdjustmentReport* report = nullptr);

struct PoseGraphEdge {
  int from = -1, to = -1;
  Sim3d from_from_to;  ///< Measured relative similarity.
  double weight = 1.0;
};

/// Sim(3) pose graph over keyframes: returns corrected world_from_keyframe
/// similarities for `nodes` (initial values given); `fixed` nodes do not move.
std::map<int, Sim3d> optimisePoseGraph(const std::map<int, Sim3d>& nodes,
                                       const std::vector<PoseGraphEdge>& edges,
                                       const std::set<int>& fixed, int iterations, int threads);

}  // namespace lookboth::vo
