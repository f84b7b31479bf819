#include "lookboth/sim/motion.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <random>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

double wrapAngle(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a <= -kPi) a += 2 * kPi;
  return a;
}

double cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

}  // namespace

std::string MotionSpec::check() const {
  if (loop.size() < 3) return "'loop': needs at least 3 points, got " + std::to_string(loop.size());
  for (const Eigen::Vector2d& p : loop) {
    if (!p.allFinite()) return "'loop': a point is not finite";
  }
  for (size_t i = 0; i < loop.size(); ++i) {
    if ((loop[(i + 1) % loop.size()] - loop[i]).norm() < 1e-3)
      return "'loop': points " + std::to_string(i) + " and " +
             std::to_string((i + 1) % loop.size()) + " coincide";
  }
  if (!(corner_radius_m > 0) || corner_radius_m > 50)
    return "'corner_radius_m': must be in (0, 50], got " + formatDouble(corner_radius_m);
  if (!(max_speed_mps > 0) || max_speed_mps > 2)
    return "'max_speed_mps': must be in (0, 2], got " + formatDouble(max_speed_mps);
  if (!(max_acceleration_mps2 > 0) || max_acceleration_mps2 > 5)
    return "'max_acceleration_mps2': must be in (0, 5], got " + formatDouble(max_acceleration_mps2);
  if (!(max_lateral_acceleration_mps2 > 0) || max_lateral_acceleration_mps2 > 5)
    return "'max_lateral_acceleration_mps2': must be in (0, 5], got " +
           formatDouble(max_lateral_acceleration_mps2);
  if (!(speed_smoothing_m >= 0) || speed_smoothing_m > 10)
    return "'speed_smoothing_m': must be in [0, 10], got " + formatDouble(speed_smoothing_m);
  if (laps < 1 || laps > 100) return "'laps': must be in [1, 100], got " + std::to_string(laps);
  if (!(wait_s >= 0) || wait_s > 60)
    return "'wait_s': must be in [0, 60], got " + formatDouble(wait_s);
  if (!(floor_amplitude_m >= 0) || floor_amplitude_m > 0.05)
    return "'floor_amplitude_m': must be in [0, 0.05], got " + formatDouble(floor_amplitude_m);
  if (!(floor_wavelength_m >= 0.5) || floor_wavelength_m > 100)
    return "'floor_wavelength_m': must be in [0.5, 100], got " + formatDouble(floor_wavelength_m);
  return "";
}

double polygonLength(const std::vector<Eigen::Vector2d>& loop) {
  double length = 0;
  for (size_t i = 0; i < loop.size(); ++i) length += (loop[(i + 1) % loop.size()] - loop[i]).norm();
  return length;
}

std::vector<Eigen::Vector2d> generateCombLoop(double length_m, double width_m, double margin_m,
                                              int notches, double target_length_m) {
  const double inner_length = length_m - 2 * margin_m;
  const double inner_width = width_m - 2 * margin_m;
  if (!(inner_length > 2) || !(inner_width > 2))
    throw Error("'generate': the facility is too small for a loop at " + formatDouble(margin_m) +
                " m from the walls");
  if (notches < 0 || notches > 20)
    throw Error("'generate.notches': must be in [0, 20], got " + std::to_string(notches));
  const double rectangle = 2 * (inner_length + inner_width);
  if (notches == 0) {
    if (std::abs(rectangle - target_length_m) > 0.1 * target_length_m)
      throw Error("'generate.length_m': without notches the loop is " + formatDouble(rectangle) +
                  " m long, not " + formatDouble(target_length_m));
  } else if (target_length_m < rectangle) {
    throw Error("'generate.length_m': " + formatDouble(target_length_m) +
                " m is shorter than the rectangle at the margin (" + formatDouble(rectangle) +
                " m)");
  }
  const double depth = notches == 0 ? 0 : (target_length_m - rectangle) / (2.0 * notches);
  const double min_gap = 2.5;  // between a notch's bottom and the near side [m]
  if (depth > inner_width - min_gap)
    throw Error("'generate.length_m': " + formatDouble(target_length_m) +
                " m does not fit: the notches would be " + formatDouble(depth) +
                " m deep in a loop " + formatDouble(inner_width) + " m wide (add notches)");
  const double pitch = notches == 0 ? 0 : inner_length / notches;
  const double notch_width = std::min(4.0, 0.5 * pitch);
  const double x0 = margin_m, y0 = margin_m, x1 = length_m - margin_m, y1 = width_m - margin_m;
  std::vector<Eigen::Vector2d> loop = {{x0, y0}, {x1, y0}, {x1, y1}};
  for (int i = notches - 1; i >= 0; --i) {
    const double centre = x0 + pitch * (i + 0.5);
    const double right = centre + 0.5 * notch_width, left = centre - 0.5 * notch_width;
    loop.emplace_back(right, y1);
    loop.emplace_back(right, y1 - depth);
    loop.emplace_back(left, y1 - depth);
    loop.emplace_back(left, y1);
  }
  loop.emplace_back(x0, y1);
  return loop;
}

RobotMotion::RobotMotion(const MotionSpec& spec, std::uint32_t seed) : spec_(spec) {
  if (const std::string why = spec.check(); !why.empty()) throw Error(why);
  // --- Geometry: straight segments joined by arcs.
  const size_t n = spec.loop.size();
  struct Corner {
    Eigen::Vector2d a, b;  // where the arc starts and ends
    double heading_in = 0, turn = 0, radius = 0;
  };
  std::vector<Corner> corners(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& prev = spec.loop[(i + n - 1) % n];
    const Eigen::Vector2d& p = spec.loop[i];
    const Eigen::Vector2d& next = spec.loop[(i + 1) % n];
    const Eigen::Vector2d d_in = (p - prev).normalized(), d_out = (next - p).normalized();
    Corner& c = corners[i];
    c.heading_in = std::atan2(d_in.y(), d_in.x());
    c.turn = std::atan2(cross2(d_in, d_out), d_in.dot(d_out));
    if (std::abs(std::abs(c.turn) - kPi) < 1e-6)
      throw Error("'loop': the path turns back on itself at point " + std::to_string(i));
    const double half_tan = std::tan(0.5 * std::abs(c.turn));
    const double room = 0.45 * std::min((p - prev).norm(), (next - p).norm());
    c.radius = half_tan > 1e-9 ? std::min(spec.corner_radius_m, room / half_tan) : 0;
    const double tangent = c.radius * half_tan;
    c.a = p - tangent * d_in;
    c.b = p + tangent * d_out;
  }
  double s = 0;
  for (size_t i = 0; i < n; ++i) {
    const Corner& c = corners[i];
    const Corner& next = corners[(i + 1) % n];
    Segment line;
    line.start = c.b;
    line.heading = wrapAngle(c.heading_in + c.turn);
    line.length = (next.a - c.b).norm();
    line.s0 = s;
    s += line.length;
    segments_.push_back(line);
    if (next.radius > 0 && std::abs(next.turn) > 1e-9) {
      Segment arc;
      arc.start = next.a;
      arc.heading = next.heading_in;
      arc.curvature = (next.turn > 0 ? 1.0 : -1.0) / next.radius;
      arc.length = next.radius * std::abs(next.turn);
      arc.s0 = s;
      s += arc.length;
      segments_.push_back(arc);
    }
  }
  loop_length_ = s;
  for (double u = 0; u < loop_length_; u += 0.05) loop_samples_.push_back(loopPoint(u));

  // --- Speed profile over all laps, on a grid of arc length.
  const double total = pathLength();
  const size_t count = static_cast<size_t>(std::ceil(total / ds_)) + 1;
  ds_ = total / static_cast<double>(count - 1);
  const int half_window = static_cast<int>(std::round(0.5 * spec.speed_smoothing_m / ds_));
  std::vector<double> local_limit(count);
  for (size_t i = 0; i < count; ++i) {
    const double kappa = std::abs(loopCurvature(static_cast<double>(i) * ds_));
    local_limit[i] = kappa > 0 ? std::min(spec.max_speed_mps * spec.max_speed_mps,
                                          spec.max_lateral_acceleration_mps2 / kappa)
                               : spec.max_speed_mps * spec.max_speed_mps;
  }
  // Limit on v^2: the smallest local limit within the smoothing window, so
  // that the moving average stays under the local limit everywhere.
  std::vector<double> v2(count);
  {
    // Sliding minimum over [i - w, i + w] with a monotonic deque.
    const size_t w = static_cast<size_t>(half_window);
    std::deque<size_t> window;  // indices with increasing limits
    size_t next = 0;
    for (size_t i = 0; i < count; ++i) {
      const size_t hi = std::min(count - 1, i + w);
      for (; next <= hi; ++next) {
        while (!window.empty() && local_limit[window.back()] >= local_limit[next])
          window.pop_back();
        window.push_back(next);
      }
      while (window.front() + w < i) window.pop_front();
      v2[i] = local_limit[window.front()];
    }
  }
  // Starting and stopping with a limited jerk j (the acceleration builds up
  // over half a second): from rest, v = j t^2 / 2 and s = j t^3 / 6, so
  // v^2 = (1/4) j^(2/3) 6^(4/3) s^(4/3) within distance s of either end.
  {
    const double jerk = 2.0 * spec.max_acceleration_mps2;
    const double k = 0.25 * std::pow(jerk, 2.0 / 3.0) * std::pow(6.0, 4.0 / 3.0);
    for (size_t i = 0; i < count; ++i) {
      const double from_end = static_cast<double>(std::min(i, count - 1 - i)) * ds_;
      v2[i] = std::min(v2[i], k * std::pow(from_end, 4.0 / 3.0));
    }
  }
  v2.front() = 0;
  v2.back() = 0;
  const double two_a_ds = 2 * spec.max_acceleration_mps2 * ds_;
  for (size_t i = 1; i < count; ++i) v2[i] = std::min(v2[i], v2[i - 1] + two_a_ds);
  for (size_t i = count - 1; i-- > 0;) v2[i] = std::min(v2[i], v2[i + 1] + two_a_ds);
  // Moving average of v^2 (keeps |d(v^2)/ds| <= 2a, so the tangential
  // acceleration bound holds, and makes the acceleration continuous). The
  // window shrinks symmetrically at the ends so that v = 0 there.
  if (half_window > 0) {
    std::vector<double> prefix(count + 1, 0.0);
    for (size_t i = 0; i < count; ++i) prefix[i + 1] = prefix[i] + v2[i];
    std::vector<double> smoothed(count);
    for (size_t i = 0; i < count; ++i) {
      const size_t w = std::min({static_cast<size_t>(half_window), i, count - 1 - i});
      smoothed[i] = (prefix[i + w + 1] - prefix[i - w]) / static_cast<double>(2 * w + 1);
    }
    v2 = std::move(smoothed);
  }
  speed_.resize(count);
  time_.resize(count);
  for (size_t i = 0; i < count; ++i) speed_[i] = std::sqrt(std::max(0.0, v2[i]));
  time_[0] = 0;
  for (size_t i = 1; i < count; ++i) {
    // Trapezoid (constant acceleration); 3 ds / v from or to rest, where
    // the jerk-limited start gives s ~ t^3.
    const double v_sum = speed_[i - 1] + speed_[i];
    const bool at_rest = speed_[i - 1] == 0 || speed_[i] == 0;
    time_[i] = time_[i - 1] + (v_sum > 1e-12 ? (at_rest ? 3 : 2) * ds_ / v_sum : 0.0);
  }

  // --- Floor.
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> angle(0, 2 * kPi);
  const double scales[3] = {1.0, 0.77, 1.31};
  for (int k = 0; k < 3; ++k) {
    const double direction = angle(rng);
    floor_directions_.row(k) << std::cos(direction), std::sin(direction);
    floor_wavenumbers_[k] = 2 * kPi / (spec.floor_wavelength_m * scales[k]);
    floor_phases_[k] = angle(rng);
  }
}

double RobotMotion::duration() const { return time_.back() + 2 * spec_.wait_s; }

const RobotMotion::Segment& RobotMotion::segmentAt(double s_mod) const {
  // Segments are few (tens): a binary search on s0.
  auto it = std::upper_bound(segments_.begin(), segments_.end(), s_mod,
                             [](double value, const Segment& seg) { return value < seg.s0; });
  if (it == segments_.begin()) return segments_.front();
  return *(it - 1);
}

Eigen::Vector2d RobotMotion::loopPoint(double s) const {
  double s_mod = std::fmod(s, loop_length_);
  if (s_mod < 0) s_mod += loop_length_;
  const Segment& seg = segmentAt(s_mod);
  const double u = std::clamp(s_mod - seg.s0, 0.0, seg.length);
  const double h0 = seg.heading;
  if (seg.curvature == 0) return seg.start + u * Eigen::Vector2d(std::cos(h0), std::sin(h0));
  const double k = seg.curvature;
  const double h = h0 + k * u;
  return seg.start +
         Eigen::Vector2d((std::sin(h) - std::sin(h0)) / k, (std::cos(h0) - std::cos(h)) / k);
}

double RobotMotion::loopHeading(double s) const {
  double s_mod = std::fmod(s, loop_length_);
  if (s_mod < 0) s_mod += loop_length_;
  const Segment& seg = segmentAt(s_mod);
  return wrapAngle(seg.heading + seg.curvature * std::clamp(s_mod - seg.s0, 0.0, seg.length));
}

double RobotMotion::loopCurvature(double s) const {
  double s_mod = std::fmod(s, loop_length_);
  if (s_mod < 0) s_mod += loop_length_;
  return segmentAt(s_mod).curvature;
}

double RobotMotion::distanceToLoop(const Eigen::Vector2d& p) const {
  double best = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < loop_samples_.size(); ++i) {
    const Eigen::Vector2d& a = loop_samples_[i];
    const Eigen::Vector2d& b = loop_samples_[(i + 1) % loop_samples_.size()];
    const Eigen::Vector2d ab = b - a;
    const double len2 = ab.squaredNorm();
    const double u = len2 > 0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, (a + u * ab - p).norm());
  }
  return best;
}

namespace {

/// Cubic Hermite interpolation of s(tau) on one grid interval (s0, v0) ->
/// (s1, v1) of duration T, at u = tau / T: the constant-acceleration
/// parabola when s1 - s0 = T (v0 + v1) / 2, the jerk-limited cubic when one
/// end is at rest and T = 3 (s1 - s0) / v. Returns (s, v).
std::pair<double, double> hermite(double s0, double v0, double s1, double v1, double T, double u) {
  const double u2 = u * u, u3 = u2 * u;
  const double s = (2 * u3 - 3 * u2 + 1) * s0 + (u3 - 2 * u2 + u) * T * v0 +
                   (-2 * u3 + 3 * u2) * s1 + (u3 - u2) * T * v1;
  const double v = ((6 * u2 - 6 * u) * s0 + (3 * u2 - 4 * u + 1) * T * v0 + (-6 * u2 + 6 * u) * s1 +
                    (3 * u2 - 2 * u) * T * v1) /
                   T;
  return {s, v};
}

}  // namespace

std::pair<double, double> RobotMotion::stateAt(double t) const {
  const double tau = std::clamp(t - spec_.wait_s, 0.0, time_.back());
  const auto it = std::upper_bound(time_.begin(), time_.end(), tau);
  if (it == time_.end()) return {pathLength(), 0.0};
  const size_t i = static_cast<size_t>(it - time_.begin()) - 1;
  const double T = time_[i + 1] - time_[i];
  const double s0 = static_cast<double>(i) * ds_;
  if (T <= 0) return {s0, speed_[i]};
  const auto [s, v] = hermite(s0, speed_[i], s0 + ds_, speed_[i + 1], T, (tau - time_[i]) / T);
  return {std::clamp(s, s0, s0 + ds_), std::max(0.0, v)};
}

double RobotMotion::arcLengthAt(double t) const { return stateAt(t).first; }

double RobotMotion::speedAt(double t) const { return stateAt(t).second; }

double RobotMotion::floorHeight(double x, double y) const {
  double h = 0;
  for (int k = 0; k < 3; ++k) {
    const double phase =
        floor_wavenumbers_[k] * (floor_directions_(k, 0) * x + floor_directions_(k, 1) * y) +
        floor_phases_[k];
    h += std::sin(phase);
  }
  return spec_.floor_amplitude_m * h / std::sqrt(3.0);
}

Eigen::Vector2d RobotMotion::floorGradient(double x, double y) const {
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  for (int k = 0; k < 3; ++k) {
    const double phase =
        floor_wavenumbers_[k] * (floor_directions_(k, 0) * x + floor_directions_(k, 1) * y) +
        floor_phases_[k];
    g += std::cos(phase) * floor_wavenumbers_[k] *
         Eigen::Vector2d(floor_directions_(k, 0), floor_directions_(k, 1));
  }
  return spec_.floor_amplitude_m * g / std::sqrt(3.0);
}

Rigid3d RobotMotion::worldFromBase(double t) const {
  const double s = arcLengthAt(t);
  const Eigen::Vector2d p = loopPoint(s);
  const double yaw = loopHeading(s);
  const Eigen::Vector2d g = floorGradient(p.x(), p.y());
  // z along the floor's normal, x forward in the floor's tangent plane.
  const Eigen::Vector3d z = Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
  const Eigen::Vector3d x =
      Eigen::Vector3d(std::cos(yaw), std::sin(yaw), g.x() * std::cos(yaw) + g.y() * std::sin(yaw))
          .normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = y;
  r.col(2) = z;
  return Rigid3d(Eigen::Quaterniond(r).normalized(),
                 Eigen::Vector3d(p.x(), p.y(), floorHeight(p.x(), p.y())));
}

}  // namespace lookboth::sim
