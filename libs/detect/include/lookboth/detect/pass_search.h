// Which of an environment camera's frames to examine for the robot's marker.
//
// A fixed camera records the whole drive, but the robot passes under it for
// a few seconds: most frames cannot contain the marker. The search examines
// one frame in `step` (coarse); where the marker is found, it examines every
// frame around it, backwards and forwards, until `step` frames in a row show
// no marker, then goes on coarsely. A pass is missed only when none of its
// coarse frames shows the marker, so it must fall between two coarse frames
// (last less than `step` frames, or less than the gap between the coarse
// frames given) or be missed by the detector on each: recall is measured against
// examining every frame (doc/benchmarks.md, "Full recordings"). In a video
// whose key frames are close enough, the coarse frames are its key frames:
// the frames between them are not decoded at all.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "lookboth/geometry/time.h"

namespace lookboth {

/// The coarse step [frames] for frames at `times` (in time order): the
/// period in seconds over the median interval between frames, at least 1
/// (every frame) when `period_s` is 0 or the camera is slower than it.
std::size_t coarseStep(const std::vector<TimeNs>& times, double period_s);

class PassSearch {
 public:
  /// `frames`: how many (indices 0..frames-1, in time order); `step` >= 1:
  /// the coarse frames are every step-th and the last, and a walk ends after
  /// `step` empty frames in a row.
  PassSearch(std::size_t frames, std::size_t step);
  /// The coarse frames given instead (sorted indices, e.g. a video's key
  /// frames, which decode alone); the last frame is added.
  PassSearch(std::size_t frames, std::size_t step, std::vector<std::size_t> coarse);

  /// Examines frames through `examine(i, coarse)` (true: the marker is in
  /// frame i; `coarse`: i is looked at as a coarse frame, not in a walk
  /// around a pass), each at most once, in the order described above.
  /// Returns early when `stop` is raised.
  using Examine = std::function<bool(std::size_t, bool)>;
  void run(const Examine& examine, const std::atomic<bool>& stop);

  /// How many frames were examined.
  std::size_t examined() const { return examined_; }
  /// Whether frame i was examined, and what it showed.
  bool wasExamined(std::size_t i) const { return state_.at(i) != kUnseen; }
  bool found(std::size_t i) const { return state_.at(i) == kFound; }

 private:
  enum State : std::uint8_t { kUnseen, kEmpty, kFound };
  /// Frame i examined (once): whether it shows the marker.
  bool look(std::size_t i, bool coarse);
  /// Every frame from `from` towards `to` (exclusive), one after the other,
  /// until `step_` frames in a row are empty; returns the first index not examined.
  std::ptrdiff_t walk(std::ptrdiff_t from, std::ptrdiff_t to, std::ptrdiff_t direction);

  std::vector<State> state_;
  std::size_t step_;
  std::vector<std::size_t> coarse_;
  std::size_t examined_ = 0;
  const Examine* examine_ = nullptr;
  const std::atomic<bool>* stop_ = nullptr;
};

/// Whether a fixed camera's view changed since the last coarse frame that
/// was searched and showed no marker. The marker rides on the robot, which
/// cannot come into view, or move in it, without changing the view: a
/// coarse frame that differs from that one by at most `threshold_grey` at
/// every pixel, both reduced to area averages over `reduction` x
/// `reduction` pixels, cannot show the marker either, and need not be
/// searched. The difference is taken after the reference's exposure (a gain
/// and an offset, fitted by least squares) is made the frame's: an automatic
/// exposure changes every pixel alike, the robot a part of the view. The
/// averages keep sensor noise and compression well under the threshold; a
/// robot coming into view changes some average by far more. Comparing with
/// the last frame searched, not the last one looked at, lets slow changes
/// (a shadow, a light) add up until a frame is searched.
class SceneChange {
 public:
  /// `threshold_grey` <= 0: every frame counts as changed.
  explicit SceneChange(double threshold_grey, int reduction = 4);
  /// Whether `grey` (8-bit, one channel) differs from the reference by more
  /// than the threshold somewhere, or its exposure by more than 25 %; true
  /// without a reference. `grey` becomes the candidate for keep().
  bool changed(const cv::Mat& grey);
  /// The largest difference of `grey` from the reference [grey levels],
  /// after the exposure is matched; infinity without a reference, for a
  /// frame of another size or not grey, or an exposure more than 25 % off
  /// (what changed() compares with the threshold). `grey` becomes the
  /// candidate for keep().
  double difference(const cv::Mat& grey);
  /// The frame last given to changed() or difference() becomes the
  /// reference: it was searched and shows no marker.
  void keep();
  /// No reference: the next frame counts as changed (after a pass, a frame
  /// that could not be decoded).
  void forget();

 private:
  /// Exposure gains outside [kMinGain, 1 / kMinGain] count as a change.
  static constexpr double kMinGain = 0.8;
  double threshold_;
  int reduction_;
  /// The reference's reduction less its mean, kept with that mean and its
  /// sum of squares (compared with many frames, computed once); the last
  /// frame's reduction.
  cv::Mat reference_, candidate_;
  double reference_mean_ = 0, reference_spread_ = 0;
};

}  // namespace lookboth
