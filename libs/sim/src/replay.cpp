#include "lookboth/sim/replay.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/tum.h"
#include "lookboth/geometry/umeyama.h"

namespace lookboth::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMarginM = 0.5;
/// Half the stretch of path over which the heading is taken: long enough
/// that a hand-held or drone path's sway does not spin the robot, short
/// enough to follow its turns [m].
constexpr double kHeadingHalfSpanM = 0.25;

double seconds(TimeNs t) { return static_cast<double>(t) * 1e-9; }

Error replayError(const std::string& field, const std::string& message) {
  return Error("'robot.replay" + (field.empty() ? "" : "." + field) + "': " + message);
}

}  // namespace

std::string ReplaySpec::check() const {
  if (!active()) return "";
  if (!(scale > 0) || scale > 100)
    return "'scale': must be in (0, 100], got " + formatDouble(scale);
  if (!std::isfinite(rotate_deg)) return "'rotate_deg': not finite";
  if (!metric && odometry.empty())
    return "'metric': false describes the odometry file, and none is given";
  return "";
}

ReplayedMotion::ReplayedMotion(const ReplaySpec& spec, double length_m, double width_m)
    : spec_(spec), truth_(readTumFile(spec.path)) {
  if (truth_.size() < 2) throw replayError("path", spec.path.string() + ": fewer than 2 poses");
  const double turn = spec.rotate_deg * kPi / 180;
  rotation_ = Eigen::AngleAxisd(turn, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  std::vector<Eigen::Vector2d> raw;
  for (const StampedPose& sample : truth_.samples()) {
    raw.push_back(spec.scale * (rotation_ * sample.world_from_body.translation).head<2>());
    times_.push_back(seconds(sample.t - truth_.startTime()));
  }
  Eigen::Vector2d low = raw.front(), high = raw.front();
  for (const Eigen::Vector2d& p : raw) {
    low = low.cwiseMin(p);
    high = high.cwiseMax(p);
  }
  const Eigen::Vector2d extent = high - low;
  if (extent.x() > length_m - 2 * kMarginM || extent.y() > width_m - 2 * kMarginM) {
    throw replayError("", spec.path.string() + ": the path spans " + formatFixed(extent.x(), 1) +
                              " m x " + formatFixed(extent.y(), 1) + " m, more than the " +
                              formatFixed(length_m, 1) + " m x " + formatFixed(width_m, 1) +
                              " m facility holds " + formatFixed(kMarginM, 1) +
                              " m from its walls: give robot.replay.scale or a larger world");
  }
  shift_ = Eigen::Vector2d(0.5 * length_m, 0.5 * width_m) - 0.5 * (low + high);
  arcs_.push_back(0);
  for (size_t i = 0; i < raw.size(); ++i) {
    points_.push_back(raw[i] + shift_);
    if (i > 0) arcs_.push_back(arcs_.back() + (points_[i] - points_[i - 1]).norm());
  }
  if (arcs_.back() < 1.0) {
    throw replayError("path", spec.path.string() + ": the path is " + formatFixed(arcs_.back(), 2) +
                                  " m long; at least 1 m is needed");
  }
  // Heading: the direction of the path over +-kHeadingHalfSpanM; where the
  // recording stands still, the last heading it had (the first one it gets
  // before it moves).
  std::vector<double> heading(points_.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t i = 0; i < points_.size(); ++i) {
    const double s0 = std::max(0.0, arcs_[i] - kHeadingHalfSpanM);
    const double s1 = std::min(arcs_.back(), arcs_[i] + kHeadingHalfSpanM);
    if (s1 - s0 < kHeadingHalfSpanM) continue;
    const Eigen::Vector2d d = loopPoint(s1) - loopPoint(s0);
    if (d.norm() > 0.2 * kHeadingHalfSpanM) heading[i] = std::atan2(d.y(), d.x());
  }
  const auto first =
      std::find_if(heading.begin(), heading.end(), [](double h) { return std::isfinite(h); });
  if (first == heading.end()) throw replayError("path", spec.path.string() + ": no direction");
  double previous = *first;
  for (double& h : heading) {
    if (!std::isfinite(h)) h = previous;
    // Unwrapped, so that interpolation turns the short way.
    h = previous + std::remainder(h - previous, 2 * kPi);
    previous = h;
  }
  headings_ = std::move(heading);
}

std::pair<size_t, double> ReplayedMotion::bracket(const std::vector<double>& values, double x) {
  if (x <= values.front()) return {0, 0.0};
  if (x >= values.back()) return {values.size() - 2, 1.0};
  const size_t i =
      static_cast<size_t>(std::upper_bound(values.begin(), values.end(), x) - values.begin()) - 1;
  const double span = values[i + 1] - values[i];
  return {i, span > 0 ? (x - values[i]) / span : 0.0};
}

Rigid3d ReplayedMotion::worldFromBase(double t) const {
  const auto [i, a] = bracket(times_, t);
  const Eigen::Vector2d xy = (1 - a) * points_[i] + a * points_[i + 1];
  const double yaw = (1 - a) * headings_[i] + a * headings_[i + 1];
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                 Eigen::Vector3d(xy.x(), xy.y(), 0.0));
}

double ReplayedMotion::arcLengthAt(double t) const {
  const auto [i, a] = bracket(times_, t);
  return (1 - a) * arcs_[i] + a * arcs_[i + 1];
}

Eigen::Vector2d ReplayedMotion::loopPoint(double s) const {
  const double wrapped = s - std::floor(s / loopLength()) * loopLength();
  const auto [i, a] = bracket(arcs_, wrapped);
  return (1 - a) * points_[i] + a * points_[i + 1];
}

double ReplayedMotion::loopHeading(double s) const {
  const double wrapped = s - std::floor(s / loopLength()) * loopLength();
  const auto [i, a] = bracket(arcs_, wrapped);
  return (1 - a) * headings_[i] + a * headings_[i + 1];
}

double ReplayedMotion::distanceToLoop(const Eigen::Vector2d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i + 1 < points_.size(); ++i) {
    const Eigen::Vector2d d = points_[i + 1] - points_[i];
    const double length2 = d.squaredNorm();
    const double a = length2 > 0 ? std::clamp((p - points_[i]).dot(d) / length2, 0.0, 1.0) : 0.0;
    best = std::min(best, (points_[i] + a * d - p).norm());
  }
  return best;
}

namespace {

/// The estimate's poses inside the truth's span, with the truth there.
struct Pairs {
  std::vector<TimeNs> times;
  std::vector<Rigid3d> estimate, truth;
};

Pairs pairUp(const Trajectory& estimate, const Trajectory& truth) {
  Pairs pairs;
  // The truth may be decimated; any gap it has is bridged (a replay's truth
  // is a ground truth, smooth between its samples).
  const TimeNs max_gap = std::numeric_limits<TimeNs>::max() / 4;
  for (const StampedPose& sample : estimate.samples()) {
    const InterpolationResult at = truth.interpolate(sample.t, max_gap);
    if (!at.ok()) continue;
    pairs.times.push_back(sample.t);
    pairs.estimate.push_back(sample.world_from_body);
    pairs.truth.push_back(at.world_from_body);
  }
  return pairs;
}

}  // namespace

std::vector<ReplayedPose> replayedOdometry(const ReplayedMotion& motion) {
  const ReplaySpec& spec = motion.spec();
  const Trajectory estimate = readTumFile(spec.odometry);
  Pairs pairs = pairUp(estimate, motion.truth());
  if (pairs.times.size() < 2) {
    throw replayError("odometry", spec.odometry.string() +
                                      ": fewer than 2 poses within the time span of " +
                                      spec.path.string() + " (are they stamped by one clock?)");
  }
  // The estimate in the truth's units: a monocular estimate's scale is the
  // one a similarity alignment finds.
  double estimate_scale = 1.0;
  if (!spec.metric) {
    std::string why;
    const auto aligned = alignPoses(pairs.estimate, pairs.truth, true, &why);
    if (!aligned) throw replayError("odometry", spec.odometry.string() + ": no scale: " + why);
    estimate_scale = 1.0 / aligned->dst_from_src.scale;
    for (Rigid3d& pose : pairs.estimate) pose.translation /= estimate_scale;
  }
  // Both start together: the estimate anchored at the truth's first pose.
  const Rigid3d anchor = pairs.truth.front() * pairs.estimate.front().inverse();
  const Eigen::Matrix3d& turn = motion.facilityFromRecording();
  const Eigen::Quaterniond turn_q(turn);
  std::vector<ReplayedPose> replayed;
  for (size_t k = 0; k < pairs.times.size(); ++k) {
    const Rigid3d estimated = anchor * pairs.estimate[k];
    const Rigid3d& truth = pairs.truth[k];
    // The error in the recording's world frame, turned into the facility's.
    const Eigen::Quaterniond rotation_error = estimated.rotation * truth.rotation.conjugate();
    const Eigen::Vector3d position_error = estimated.translation - truth.translation;
    ReplayedPose pose;
    pose.t = seconds(pairs.times[k] - motion.startTime());
    const Rigid3d base = motion.worldFromBase(pose.t);
    pose.world_from_base.rotation =
        (turn_q * rotation_error * turn_q.conjugate() * base.rotation).normalized();
    pose.world_from_base.translation = base.translation + spec.scale * (turn * position_error);
    // An unscaled estimate keeps its own scale (register finds it).
    pose.world_from_base.translation *= estimate_scale;
    replayed.push_back(pose);
  }
  return replayed;
}

}  // namespace lookboth::sim
