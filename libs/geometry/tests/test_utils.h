// Random poses and matchers shared by the geometry tests.
#pragma once

#include <random>

#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/rigid3.h"

namespace lookboth::testing {

inline Eigen::Quaterniond randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized();
}

inline Rigid3d randomPose(std::mt19937& rng, double translation_scale = 10.0) {
  std::uniform_real_distribution<double> u(-translation_scale, translation_scale);
  return Rigid3d(randomRotation(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)));
}

/// Rotation angle between the two poses' rotations [rad] and distance between translations.
inline double rotationError(const Rigid3d& a, const Rigid3d& b) {
  return rotationAngleBetween(a.rotation, b.rotation);
}
inline double translationError(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm();
}

}  // namespace lookboth::testing
