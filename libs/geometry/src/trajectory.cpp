#include "lookboth/geometry/trajectory.h"

#include <algorithm>
#include <vector>

#include "lookboth/core/error.h"
#include "lookboth/geometry/lie.h"

namespace lookboth {

const char* interpolationStatusName(InterpolationStatus status) {
  switch (status) {
    case InterpolationStatus::kOk:
      return "ok";
    case InterpolationStatus::kEmpty:
      return "empty trajectory";
    case InterpolationStatus::kBeforeStart:
      return "before the first sample";
    case InterpolationStatus::kAfterEnd:
      return "after the last sample";
    case InterpolationStatus::kGapTooLong:
      return "inside a gap between samples";
  }
  return "unknown";
}

Trajectory::Trajectory(std::vector<StampedPose> samples) : samples_(std::move(samples)) {
  for (size_t i = 1; i < samples_.size(); ++i) {
    if (samples_[i].t <= samples_[i - 1].t) {
      throw Error("trajectory sample " + std::to_string(i) + " at t=" +
                  formatSeconds(samples_[i].t) + " s is not later than the previous one (" +
                  formatSeconds(samples_[i - 1].t) + " s): timestamps must strictly increase");
    }
  }
}

void Trajectory::append(TimeNs t, const Rigid3d& world_from_body) {
  if (!samples_.empty() && t <= samples_.back().t) {
    throw Error("trajectory sample at t=" + formatSeconds(t) +
                " s is not later than the last one (" + formatSeconds(samples_.back().t) +
                " s): timestamps must strictly increase");
  }
  samples_.push_back({t, world_from_body});
}

InterpolationResult Trajectory::interpolate(TimeNs t, TimeNs max_gap) const {
  InterpolationResult result;
  if (samples_.empty()) {
    result.status = InterpolationStatus::kEmpty;
    return result;
  }
  if (t < samples_.front().t) {
    result.status = InterpolationStatus::kBeforeStart;
    result.t_after = samples_.front().t;
    return result;
  }
  if (t > samples_.back().t) {
    result.status = InterpolationStatus::kAfterEnd;
    result.t_before = samples_.back().t;
    return result;
  }
  // First sample with time >= t.
  const auto after = std::lower_bound(samples_.begin(), samples_.end(), t,
                                      [](const StampedPose& s, TimeNs q) { return s.t < q; });
  if (after->t == t) {
    result.status = InterpolationStatus::kOk;
    result.world_from_body = after->world_from_body;
    result.t_before = result.t_after = t;
    return result;
  }
  const auto before = after - 1;
  result.t_before = before->t;
  result.t_after = after->t;
  const TimeNs span = after->t - before->t;
  if (max_gap > 0 && span > max_gap) {
    result.status = InterpolationStatus::kGapTooLong;
    return result;
  }
  const double alpha = static_cast<double>(t - before->t) / static_cast<double>(span);
  result.world_from_body =
      interpolateLinearSlerp(before->world_from_body, after->world_from_body, alpha);
  result.status = InterpolationStatus::kOk;
  return result;
}

TimeNs Trajectory::medianInterval() const {
  if (samples_.size() < 2) return 0;
  std::vector<TimeNs> intervals(samples_.size() - 1);
  for (std::size_t i = 0; i + 1 < samples_.size(); ++i) {
    intervals[i] = samples_[i + 1].t - samples_[i].t;
  }
  const auto middle = intervals.begin() + static_cast<std::ptrdiff_t>(intervals.size() / 2);
  std::nth_element(intervals.begin(), middle, intervals.end());
  return *middle;
}

TimeNs effectiveMaxGap(const Trajectory& trajectory, TimeNs max_gap) {
  if (max_gap <= 0) return max_gap;
  return std::max(max_gap, 10 * trajectory.medianInterval());
}

}  // namespace lookboth
