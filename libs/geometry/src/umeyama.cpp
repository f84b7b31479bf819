#include "lookboth/geometry/umeyama.h"

#include <Eigen/SVD>
#include <cmath>

namespace lookboth {
namespace {

std::optional<AlignmentResult> align(const std::vector<Eigen::Vector3d>& src,
                                     const std::vector<Eigen::Vector3d>& dst,
                                     const std::vector<double>& weights, bool with_scale,
                                     std::string* why_not) {
  auto fail = [&](const std::string& reason) -> std::optional<AlignmentResult> {
    if (why_not) *why_not = reason;
    return std::nullopt;
  };
  if (src.size() != dst.size()) {
    return fail("different numbers of points (" + std::to_string(src.size()) + " and " +
                std::to_string(dst.size()) + ")");
  }
  if (!weights.empty() && weights.size() != src.size()) {
    return fail("one weight per point expected");
  }
  if (src.size() < 3) {
    return fail("at least 3 corresponding points are needed, got " + std::to_string(src.size()));
  }
  const size_t n = src.size();
  double weight_sum = 0.0;
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_dst = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    if (!(w >= 0.0) || !std::isfinite(w)) return fail("weights must be finite and non-negative");
    if (!src[i].allFinite() || !dst[i].allFinite()) {
      return fail("point " + std::to_string(i) + " is not finite");
    }
    weight_sum += w;
    mean_src += w * src[i];
    mean_dst += w * dst[i];
  }
  if (weight_sum <= 0.0) return fail("all weights are zero");
  mean_src /= weight_sum;
  mean_dst /= weight_sum;

  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // sum w (dst - mu)(src - mu)^T / W
  double src_variance = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    const Eigen::Vector3d s = src[i] - mean_src;
    const Eigen::Vector3d d = dst[i] - mean_dst;
    covariance += w * d * s.transpose();
    src_variance += w * s.squaredNorm();
  }
  covariance /= weight_sum;
  src_variance /= weight_sum;

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(covariance,
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d singular = svd.singularValues();
  // The rotation is determined when the cross-covariance has rank >= 2.
  if (src_variance <= 0.0 || singular(1) <= 1e-12 * std::max(singular(0), 1e-300)) {
    return fail(
        "points are coincident or collinear: the rotation about their line is undetermined");
  }
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s(2, 2) = -1.0;
  const Eigen::Matrix3d rotation = svd.matrixU() * s * svd.matrixV().transpose();
  const double scale = with_scale ? (singular.asDiagonal() * s).trace() / src_variance : 1.0;
  if (!(scale > 0.0)) return fail("degenerate configuration (non-positive scale)");

  AlignmentResult result;
  Eigen::Quaterniond q(rotation);
  q.normalize();
  result.dst_from_src = Sim3d(scale, q, mean_dst - scale * (rotation * mean_src));
  double squared = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double w = weights.empty() ? 1.0 : weights[i];
    squared += w * (dst[i] - result.dst_from_src * src[i]).squaredNorm();
  }
  result.rms_error = std::sqrt(squared / weight_sum);
  return result;
}

}  // namespace

std::optional<AlignmentResult> alignSim3(const std::vector<Eigen::Vector3d>& src,
                                         const std::vector<Eigen::Vector3d>& dst,
                                         const std::vector<double>& weights, std::string* why_not) {
  return align(src, dst, weights, /*with_scale=*/true, why_not);
}

std::optional<AlignmentResult> alignRigid3(const std::vector<Eigen::Vector3d>& src,
                                           const std::vector<Eigen::Vector3d>& dst,
                                           const std::vector<double>& weights,
                                           std::string* why_not) {
  return align(src, dst, weights, /*with_scale=*/false, why_not);
}

std::optional<AlignmentResult> alignPoses(const std::vector<Rigid3d>& a_from_x,
                                          const std::vector<Rigid3d>& b_from_x, bool with_scale,
                                          std::string* why_not) {
  std::vector<Eigen::Vector3d> src, dst;
  src.reserve(a_from_x.size());
  dst.reserve(b_from_x.size());
  for (const Rigid3d& p : a_from_x) src.push_back(p.translation);
  for (const Rigid3d& p : b_from_x) dst.push_back(p.translation);
  return align(src, dst, {}, with_scale, why_not);
}

}  // namespace lookboth
