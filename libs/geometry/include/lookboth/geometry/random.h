// Random vectors drawn in one fixed order on every compiler.
//
// `Eigen::Vector3d(n(rng), n(rng), n(rng))` leaves the order of the three
// draws to the compiler: gcc evaluates the last argument first, clang the
// first. The same seed then gives another noise realisation under clang, and
// a test or dataset is no longer the same experiment on both. drawVector()
// sequences the draws: the last coefficient first, the order gcc gives the
// unsequenced form, so that the datasets and tests written with it keep their
// noise.
#pragma once

#include <Eigen/Core>

namespace lookboth {

/// A vector of N draws: `draw()` is called N times, for coefficient N-1 first
/// and coefficient 0 last. E.g. `drawVector<3>([&] { return n(rng); })`.
template <int N, class Draw>
Eigen::Matrix<double, N, 1> drawVector(Draw&& draw) {
  Eigen::Matrix<double, N, 1> v;
  for (int i = N - 1; i >= 0; --i) v[i] = draw();
  return v;
}

}  // namespace lookboth
