// Random poses and matchers shared by the geometry tests.
#pragma once

#include <random>

#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"
#include "lookboth/geometry/rigid3.h"

namespace lookboth::testing {

inline Eigen::Quaterniond randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector4d wxyz = drawVector<4>([&] { return n(rng); });
  return Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]).normalized();
}

inline Rigid3d randomPose(std::mt19937& rng, double translation_scale = 10.0) {
  std::uniform_real_distribution<double> u(-translation_scale, translation_scale);
  const Eigen::Vector3d t = drawVector<3>([&] { return u(rng); });
  return Rigid3d(randomRotation(rng), t);
}

/// Rotation angle between the two poses' rotations [rad] and distance between translations.
inline double rotationError(const Rigid3d& a, const Rigid3d& b) {
  return rotationAngleBetween(a.rotation, b.rotation);
}
inline double translationError(const Rigid3d& a, const Rigid3d& b) {
  return (a.translation - b.translation).norm();
}

}  // namespace lookboth::testing
