// Replays of recorded drives (doc/formats.md, "Scenario files", robot.replay).
//
// The simulator's own drift model is a yardstick we wrote; a replay puts the
// errors of a real estimator into a simulated facility. The robot follows a
// recorded path (a real ground truth, TUM), projected onto the floor as a
// wheeled robot would drive it (heading along the path); the cameras are
// placed along it. The odometry handed to `register` is, when given, a real
// estimate of the same drive: at each of its poses, its error against the
// ground truth (world-frame rotation error and position error, after
// anchoring both at the estimate's first pose) is applied to the replayed
// pose. So the registration meets that estimator's drift as it was: its
// correlation over metres, its concentration in turns, its jumps at loop
// closures, its scale drift.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/trajectory.h"
#include "lookboth/sim/motion.h"

namespace lookboth::sim {

struct ReplaySpec {
  /// TUM file of the true path (world_from_body; only its positions are
  /// used, projected onto the floor). Empty: no replay.
  std::filesystem::path path;
  /// TUM file of an estimate of the same drive (same clock); empty: the
  /// simulated wheel odometry (robot.odometry).
  std::filesystem::path odometry;
  /// false: the estimate's scale is unknown (a monocular estimate): its
  /// error is taken after a similarity alignment's scale, and the odometry
  /// written keeps the estimate's own scale, marked not metric.
  bool metric = true;
  double scale = 1.0;       ///< Both files' positions multiplied by this [-], (0, 100].
  double rotate_deg = 0.0;  ///< The path turned about the vertical before centring [deg].
  bool active() const { return !path.empty(); }
  /// Empty when valid; else "'field': message".
  std::string check() const;
};

/// The robot driving a recorded path (replay.h's header says how).
class ReplayedMotion : public RobotPath {
 public:
  /// Reads spec.path and centres the projected path in a facility of
  /// length x width [m]. Throws lookboth::Error naming the file (and line)
  /// for a bad file, and "'robot.replay...'" when the path does not fit
  /// 0.5 m inside the walls or is shorter than 1 m.
  ReplayedMotion(const ReplaySpec& spec, double length_m, double width_m);

  double duration() const override { return times_.back(); }
  Rigid3d worldFromBase(double t) const override;
  double arcLengthAt(double t) const override;
  double loopLength() const override { return arcs_.back(); }
  Eigen::Vector2d loopPoint(double s) const override;
  double loopHeading(double s) const override;
  double distanceToLoop(const Eigen::Vector2d& p) const override;

  /// Time of the first sample of the recording [its clock, ns]: time 0 here.
  TimeNs startTime() const { return truth_.startTime(); }
  /// The turn (rotate_deg about the vertical) from the recording's world to
  /// the facility's; positions are then scaled and shifted onto the floor.
  const Eigen::Matrix3d& facilityFromRecording() const { return rotation_; }
  const ReplaySpec& spec() const { return spec_; }
  /// The recorded true path as read.
  const Trajectory& truth() const { return truth_; }

 private:
  /// Index i with values[i] <= x < values[i + 1] (clamped), and the fraction.
  static std::pair<size_t, double> bracket(const std::vector<double>& values, double x);

  ReplaySpec spec_;
  Trajectory truth_;
  Eigen::Matrix3d rotation_ = Eigen::Matrix3d::Identity();
  Eigen::Vector2d shift_ = Eigen::Vector2d::Zero();
  std::vector<double> times_;            ///< [s since the start]
  std::vector<double> arcs_;             ///< Distance travelled at each sample [m].
  std::vector<Eigen::Vector2d> points_;  ///< On the facility's floor [m].
  std::vector<double> headings_;         ///< Unwrapped, along the path [rad].
};

/// One odometry pose of a replay: time since the start [s], world_from_base.
struct ReplayedPose {
  double t = 0;
  Rigid3d world_from_base;
};

/// The estimate of spec.odometry with its error carried onto the replayed
/// drive (replay.h's header says how), at the estimate's own times within
/// the true path's span. Throws lookboth::Error naming the file for a bad
/// file, fewer than 2 poses in the span, or (metric false) a path along
/// which the scale cannot be found.
std::vector<ReplayedPose> replayedOdometry(const ReplayedMotion& motion);

}  // namespace lookboth::sim
