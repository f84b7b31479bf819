// Private: where a time falls between two trajectory nodes of stage `joint`
// (joint_adjustment.h), the pose there, and the input's smoothing: what
// every step of the stage uses, without the costs (joint_costs.h).
#pragma once
#include <cmath>
#include <cstddef>
#include <vector>

#include "lookboth/geometry/trajectory.h"
#include "pose_costs.h"

namespace lookboth::joint_detail {

constexpr std::size_t kMaxParams = 64;  // camera model parameters a cost can carry

// Where a time falls between two nodes and the reference trajectory there.
struct Bracket {
  std::size_t k = 0;                                         // node index (k, k+1)
  double duration_s = 1;                                     // t_k+1 - t_k
  double tau_ref_s = 0;                                      // reference time - t_k [s]
  Rigid3d ref_inverse_k, ref_inverse_k1;                     // Nref^-1 at the two nodes
  Rigid3d reference;                                         // Fref at the reference time
  Eigen::Vector3d velocity_world = Eigen::Vector3d::Zero();  // [m/s]
  Eigen::Vector3d omega_body = Eigen::Vector3d::Zero();      // [rad/s]
};

template <typename T>
Rigid3<T> poseAt(const Bracket& b, const T* node_k, const T* node_k1, const T& tau) {
  const Rigid3<T> ck = poseFromParams(node_k) * b.ref_inverse_k.cast<T>();
  const Rigid3<T> ck1 = poseFromParams(node_k1) * b.ref_inverse_k1.cast<T>();
  // The correction is interpolated inside the bracket and held at the nearer
  // node's outside it (a clock offset that moved the time out of its bracket
  // during a round; the next round brackets it anew). Extrapolated, the two
  // nodes' difference would be amplified by the offset's excursion: a lever
  // with which the optimiser fitted detection noise by running every camera's
  // clock and the marker's mount away together (doc/benchmarks-history.md, "A time
  // outside its bracket": 0.4 m and 0.4 s on the 1,000-camera facility).
  T alpha = tau / T(b.duration_s);
  if (alpha < T(0)) alpha = T(0);
  if (alpha > T(1)) alpha = T(1);
  const Eigen::Matrix<T, 3, 1> w =
      so3Log(Eigen::Quaternion<T>(ck.rotation.conjugate() * ck1.rotation));
  const Eigen::Matrix<T, 3, 1> wa = w * alpha;
  const Rigid3<T> correction(ck.rotation * so3Exp(wa),
                             ck.translation + (ck1.translation - ck.translation) * alpha);
  const T delta = tau - T(b.tau_ref_s);
  const Eigen::Matrix<T, 3, 1> wd = b.omega_body.cast<T>() * delta;
  const Rigid3<T> reference(b.reference.rotation.cast<T>() * so3Exp(wd),
                            b.reference.translation.cast<T>() + b.velocity_world.cast<T>() * delta);
  return correction * reference;
}

// The input trajectory's positions, each replaced by a local quadratic fit in
// time (Savitzky-Golay) over the samples within +-half_window_s of it and
// without a gap longer than max_gap_ns between them; orientations unchanged.
// A quadratic fit leaves a constant acceleration (a turn at constant speed)
// unbiased, where a moving average would pull the path inwards; it removes a
// visual odometry's frame-to-frame position jitter, which the interpolation
// between nodes would otherwise hand to every detection. Fewer than 5 samples
// in the window: the sample is kept.
// `residual_rms_m` (optional): the RMS of the samples' distances to their
// fits, the input's scatter about a smooth motion (0 when nothing was fitted).
inline std::vector<StampedPose> smoothPositions(const std::vector<StampedPose>& in,
                                                double half_window_s, TimeNs max_gap_ns,
                                                double* residual_rms_m = nullptr) {
  std::vector<StampedPose> out = in;
  if (residual_rms_m) *residual_rms_m = 0;
  if (!(half_window_s > 0)) return out;
  double sum = 0;
  std::size_t fitted = 0;
  const TimeNs w = static_cast<TimeNs>(half_window_s * 1e9);
  for (std::size_t i = 0; i < in.size(); ++i) {
    std::size_t lo = i, hi = i;
    while (lo > 0 && in[i].t - in[lo - 1].t <= w && in[lo].t - in[lo - 1].t <= max_gap_ns) --lo;
    while (hi + 1 < in.size() && in[hi + 1].t - in[i].t <= w &&
           in[hi + 1].t - in[hi].t <= max_gap_ns) {
      ++hi;
    }
    if (hi - lo + 1 < 5) continue;
    Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d rhs = Eigen::Matrix3d::Zero();  // column per axis
    for (std::size_t j = lo; j <= hi; ++j) {
      const double tau = static_cast<double>(in[j].t - in[i].t) * 1e-9;
      const Eigen::Vector3d basis(1.0, tau, tau * tau);
      normal += basis * basis.transpose();
      rhs += basis * in[j].world_from_body.translation.transpose();
    }
    const Eigen::Matrix3d coefficients = normal.ldlt().solve(rhs);  // rows: 1, tau, tau^2
    if (!coefficients.allFinite()) continue;
    out[i].world_from_body.translation = coefficients.row(0).transpose();
    sum += (out[i].world_from_body.translation - in[i].world_from_body.translation).squaredNorm();
    ++fitted;
  }
  if (residual_rms_m && fitted > 0) *residual_rms_m = std::sqrt(sum / static_cast<double>(fitted));
  return out;
}

}  // namespace lookboth::joint_detail
