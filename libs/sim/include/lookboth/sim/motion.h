// The simulated robot's motion: a closed loop on the floor (a polygon whose
// corners are rounded into circular arcs), driven `laps` times with a
// speed profile that respects a maximum speed, a maximum tangential
// acceleration and a maximum lateral (centripetal) acceleration, starting
// and ending at rest. The base frame (x forward, y left, z up) follows the
// floor, which undulates by a few millimetres: that gives the small roll and
// pitch of a real robot on a real floor.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "lookboth/geometry/rigid3.h"

namespace lookboth::sim {

struct MotionSpec {
  /// The loop: a closed polygon on the floor (the last point joins the first) [m].
  std::vector<Eigen::Vector2d> loop;
  double corner_radius_m = 1.0;                ///< Radius of the arcs that round the corners [m].
  double max_speed_mps = 1.0;                  ///< [m/s].
  double max_acceleration_mps2 = 0.3;          ///< Tangential [m/s^2].
  double max_lateral_acceleration_mps2 = 0.3;  ///< Centripetal, v^2 * curvature [m/s^2].
  double speed_smoothing_m = 0.6;    ///< Window of the moving average of v^2 along the path [m].
  int laps = 1;                      ///< Times around the loop.
  double wait_s = 1.0;               ///< Standing still before starting and after stopping [s].
  double floor_amplitude_m = 0.005;  ///< Amplitude of the floor's undulation [m].
  double floor_wavelength_m = 4.0;   ///< Its typical wavelength [m].
  /// Empty when valid; else a message naming the field.
  std::string check() const;
};

/// A comb-shaped loop inside a length x width facility: the rectangle at
/// `margin` from the walls, with `notches` U-shaped detours cut into it from
/// the far side (y = width - margin), as deep as needed to make the loop
/// `target_length` long. Throws lookboth::Error when impossible (too long for
/// the area, too short for the rectangle).
std::vector<Eigen::Vector2d> generateCombLoop(double length_m, double width_m, double margin_m,
                                              int notches, double target_length_m);

/// Length of a closed polygon [m].
double polygonLength(const std::vector<Eigen::Vector2d>& loop);

/// What the simulator needs of the robot's drive: the base frame over time
/// and the path on the floor the cameras are placed along. A drive is a
/// generated loop (RobotMotion) or a recorded path replayed (ReplayedMotion,
/// replay.h).
class RobotPath {
 public:
  virtual ~RobotPath() = default;
  /// From the start to the end of the motion [s].
  virtual double duration() const = 0;
  /// The base frame (x forward, y left, z up) at time t [s since the start].
  virtual Rigid3d worldFromBase(double t) const = 0;
  /// Distance travelled at time t [m].
  virtual double arcLengthAt(double t) const = 0;
  /// Length of the path the cameras are placed along (one lap of a loop) [m].
  virtual double loopLength() const = 0;
  /// A point of that path at arc length s (taken modulo loopLength()) [m].
  virtual Eigen::Vector2d loopPoint(double s) const = 0;
  /// Its heading at s [rad], anticlockwise from +x.
  virtual double loopHeading(double s) const = 0;
  /// Shortest horizontal distance from p to that path [m].
  virtual double distanceToLoop(const Eigen::Vector2d& p) const = 0;
};

class RobotMotion : public RobotPath {
 public:
  /// Builds the path and its speed profile; `seed` draws the floor's
  /// undulation. Throws lookboth::Error when the spec is invalid.
  RobotMotion(const MotionSpec& spec, std::uint32_t seed);

  const MotionSpec& spec() const { return spec_; }
  /// Length of one lap of the rounded loop [m].
  double loopLength() const override { return loop_length_; }
  /// Length driven in all: laps * loopLength() [m].
  double pathLength() const { return loop_length_ * spec_.laps; }
  /// From the start to the end of the motion, waits included [s].
  double duration() const override;

  /// The base frame at time t [s since the start] (clamped to [0, duration]).
  Rigid3d worldFromBase(double t) const override;
  /// Distance travelled at time t [m].
  double arcLengthAt(double t) const override;
  /// Speed at time t [m/s].
  double speedAt(double t) const;

  /// A point of the rounded loop at arc length s (taken modulo the loop length) [m].
  Eigen::Vector2d loopPoint(double s) const override;
  /// Heading of the loop at s [rad], anticlockwise from +x.
  double loopHeading(double s) const override;
  /// Signed curvature of the loop at s [1/m] (positive turning left).
  double loopCurvature(double s) const;
  /// Shortest horizontal distance from p to the rounded loop [m].
  double distanceToLoop(const Eigen::Vector2d& p) const override;

  /// Height of the floor at (x, y) [m] and its gradient.
  double floorHeight(double x, double y) const;
  Eigen::Vector2d floorGradient(double x, double y) const;

 private:
  struct Segment {
    Eigen::Vector2d start;
    double heading = 0;    ///< At the start [rad].
    double curvature = 0;  ///< 0 for a straight line [1/m].
    double length = 0;
    double s0 = 0;  ///< Arc length of the start along the loop.
  };
  const Segment& segmentAt(double s_mod) const;
  /// (arc length, speed) at time t.
  std::pair<double, double> stateAt(double t) const;

  MotionSpec spec_;
  std::vector<Segment> segments_;
  double loop_length_ = 0;
  // Speed profile on a regular grid of arc length (spacing ds_) over all laps.
  double ds_ = 0.005;
  std::vector<double> speed_;  ///< [m/s] at s = i * ds_.
  std::vector<double> time_;   ///< [s] at s = i * ds_, waits excluded.
  // Floor: sum of three plane waves.
  Eigen::Matrix<double, 3, 2> floor_directions_;
  Eigen::Vector3d floor_wavenumbers_, floor_phases_;
  std::vector<Eigen::Vector2d> loop_samples_;  ///< Every 5 cm, for distanceToLoop.
};

}  // namespace lookboth::sim
