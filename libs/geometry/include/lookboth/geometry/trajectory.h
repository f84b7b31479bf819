// A trajectory: poses of a moving frame (the robot's fisheye, a LiDAR...) in
// a fixed frame at increasing timestamps, and pose interpolation between them.
//
// Interpolation is linear in translation and slerp in rotation between the
// two samples around the query time (the paper's method). It never
// extrapolates: before the first sample, after the last one, or inside a gap
// between samples longer than the allowed maximum, the result says so.
#pragma once

#include <string>
#include <vector>

#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/time.h"

namespace lookboth {

/// world_from_body at time t: the pose of the moving frame in the fixed one.
struct StampedPose {
  TimeNs t = 0;
  Rigid3d world_from_body;
};

enum class InterpolationStatus {
  kOk,           ///< pose is valid.
  kEmpty,        ///< the trajectory has no sample.
  kBeforeStart,  ///< query earlier than the first sample.
  kAfterEnd,     ///< query later than the last sample.
  kGapTooLong,   ///< the two samples around the query are further apart than max_gap.
};

/// "ok", "empty trajectory", "before the first sample", ...
const char* interpolationStatusName(InterpolationStatus status);

struct InterpolationResult {
  InterpolationStatus status = InterpolationStatus::kEmpty;
  Rigid3d world_from_body;  ///< Valid only when status == kOk.
  TimeNs t_before = 0;      ///< Sample times around the query (when they exist).
  TimeNs t_after = 0;
  bool ok() const { return status == InterpolationStatus::kOk; }
};

class Trajectory {
 public:
  Trajectory() = default;
  /// Samples must have strictly increasing timestamps; throws lookboth::Error
  /// naming the first offending index otherwise.
  explicit Trajectory(std::vector<StampedPose> samples);

  /// Appends a sample; its time must be later than the last one (throws
  /// lookboth::Error on a duplicate or out-of-order stamp).
  void append(TimeNs t, const Rigid3d& world_from_body);

  const std::vector<StampedPose>& samples() const { return samples_; }
  size_t size() const { return samples_.size(); }
  bool empty() const { return samples_.empty(); }
  TimeNs startTime() const { return samples_.front().t; }
  TimeNs endTime() const { return samples_.back().t; }

  /// Pose at time t. Exactly a stored sample when t is a sample time.
  /// `max_gap`: the largest allowed time between the two samples around t
  /// [ns]; 0 or negative means no limit.
  InterpolationResult interpolate(TimeNs t, TimeNs max_gap) const;

  /// The median time between consecutive samples [ns]; 0 with fewer than 2.
  TimeNs medianInterval() const;

 private:
  std::vector<StampedPose> samples_;
};

/// The longest interval between two samples that interpolation may cross,
/// for a configured limit `max_gap` [ns]: the limit, or ten times the
/// trajectory's median sampling interval when that is longer. A keyframe
/// trajectory (ORB-SLAM's KeyFrameTrajectory.txt: a pose every 0.1-3 s) is
/// that sparse by design, and its intervals are not lost tracking: against
/// a limit set for a 30 Hz odometry most of its detections would be lost.
TimeNs effectiveMaxGap(const Trajectory& trajectory, TimeNs max_gap);

}  // namespace lookboth
