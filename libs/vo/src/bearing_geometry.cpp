// RANSAC on bearings around OpenGV's minimal solvers. OpenGV's sample
// consensus problems draw from their own std::mt19937; it is reseeded here
// so that results depend on the caller's seed only.
#include "lookboth/vo/bearing_geometry.h"

#include <cmath>
#include <memory>
#include <opengv/absolute_pose/CentralAbsoluteAdapter.hpp>
#include <opengv/absolute_pose/methods.hpp>
#include <opengv/relative_pose/CentralRelativeAdapter.hpp>
#include <opengv/relative_pose/methods.hpp>
#include <opengv/sac/Ransac.hpp>
#include <opengv/sac_problems/absolute_pose/AbsolutePoseSacProblem.hpp>
#include <opengv/sac_problems/relative_pose/CentralRelativePoseSacProblem.hpp>

namespace lookboth::vo {
namespace {

opengv::bearingVectors_t toOpengv(const Bearings& v) {
  opengv::bearingVectors_t out;
  out.reserve(v.size());
  for (const Eigen::Vector3d& b : v) out.push_back(b.normalized());
  return out;
}

template <typename Problem>
void reseed(Problem& problem, std::uint32_t seed) {
  problem.rng_alg_.seed(seed);
  auto* engine = &problem.rng_alg_;
  auto distribution = problem.rng_dist_;
  problem.rng_gen_ = std::make_shared<std::function<int()>>(
      [engine, distribution]() { return (*distribution)(*engine); });
}

/// OpenGV measures errors as 1 - cos(angle).
double cosineThreshold(double angle_rad) { return 1.0 - std::cos(angle_rad); }

Rigid3d fromOpengv(const opengv::transformation_t& t) {
  Eigen::Quaterniond q(Eigen::Matrix3d(t.leftCols<3>()));
  q.normalize();
  return Rigid3d(q, t.col(3));
}

}  // namespace

double angularError(const Eigen::Vector3d& bearing, const Eigen::Vector3d& p_in_camera) {
  const double n = p_in_camera.norm();
  if (n <= 0) return M_PI;
  return std::atan2(bearing.cross(p_in_camera).norm(), bearing.dot(p_in_camera));
}

std::optional<RelativePoseResult> estimateRelativePose(const Bearings& bearings1,
                                                       const Bearings& bearings2,
                                                       const RansacOptions& options) {
  if (bearings1.size() != bearings2.size() || bearings1.size() < 5) return std::nullopt;
  const opengv::bearingVectors_t b1 = toOpengv(bearings1);
  const opengv::bearingVectors_t b2 = toOpengv(bearings2);
  opengv::relative_pose::CentralRelativeAdapter adapter(b1, b2);
  using Problem = opengv::sac_problems::relative_pose::CentralRelativePoseSacProblem;
  auto problem = std::make_shared<Problem>(adapter, Problem::NISTER, false);
  reseed(*problem, options.seed);
  opengv::sac::Ransac<Problem> ransac(options.max_iterations,
                                      cosineThreshold(options.threshold_rad), options.confidence);
  ransac.sac_model_ = problem;
  if (!ransac.computeModel(0) || ransac.inliers_.size() < 5) return std::nullopt;

  // Refine on the inliers (Levenberg-Marquardt over R and the translation direction).
  adapter.sett12(ransac.model_coefficients_.col(3));
  adapter.setR12(ransac.model_coefficients_.leftCols<3>());
  opengv::transformation_t refined =
      opengv::relative_pose::optimize_nonlinear(adapter, ransac.inliers_);
  if (!refined.allFinite() || refined.col(3).norm() < 1e-12) refined = ransac.model_coefficients_;
  refined.col(3).normalize();

  std::vector<int> all(bearings1.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  std::vector<double> distances;
  problem->getSelectedDistancesToModel(refined, all, distances);
  RelativePoseResult result;
  result.cam1_from_cam2 = fromOpengv(refined);
  result.inliers.assign(all.size(), false);
  const double threshold = cosineThreshold(options.threshold_rad);
  for (size_t i = 0; i < all.size(); ++i) {
    if (distances[i] < threshold) {
      result.inliers[i] = true;
      ++result.num_inliers;
    }
  }
  if (result.num_inliers < 5) return std::nullopt;
  return result;
}

std::optional<AbsolutePoseResult> estimateAbsolutePose(
    const Bearings& bearings_in_camera, const std::vector<Eigen::Vector3d>& p_in_world,
    const RansacOptions& options) {
  if (bearings_in_camera.size() != p_in_world.size() || p_in_world.size() < 4) return std::nullopt;
  const opengv::bearingVectors_t b = toOpengv(bearings_in_camera);
  opengv::points_t points(p_in_world.begin(), p_in_world.end());
  opengv::absolute_pose::CentralAbsoluteAdapter adapter(b, points);
  using Problem = opengv::sac_problems::absolute_pose::AbsolutePoseSacProblem;
  auto problem = std::make_shared<Problem>(adapter, Problem::KNEIP, false);
  reseed(*problem, options.seed);
  opengv::sac::Ransac<Problem> ransac(options.max_iterations,
                                      cosineThreshold(options.threshold_rad), options.confidence);
  ransac.sac_model_ = problem;
  if (!ransac.computeModel(0) || ransac.inliers_.size() < 4) return std::nullopt;

  adapter.sett(ransac.model_coefficients_.col(3));
  adapter.setR(ransac.model_coefficients_.leftCols<3>());
  opengv::transformation_t refined =
      opengv::absolute_pose::optimize_nonlinear(adapter, ransac.inliers_);
  if (!refined.allFinite()) refined = ransac.model_coefficients_;

  AbsolutePoseResult result;
  result.world_from_camera = fromOpengv(refined);
  const Rigid3d camera_from_world = result.world_from_camera.inverse();
  result.inliers.assign(p_in_world.size(), false);
  for (size_t i = 0; i < p_in_world.size(); ++i) {
    if (angularError(b[i], camera_from_world * p_in_world[i]) < options.threshold_rad) {
      result.inliers[i] = true;
      ++result.num_inliers;
    }
  }
  if (result.num_inliers < 4) return std::nullopt;
  return result;
}

std::optional<Eigen::Vector3d> triangulateMidpoint(const Rigid3d& world_from_a,
                                                   const Eigen::Vector3d& bearing_a,
                                                   const Rigid3d& world_from_b,
                                                   const Eigen::Vector3d& bearing_b,
                                                   double min_angle_rad) {
  const Eigen::Vector3d da = world_from_a.rotation * bearing_a.normalized();
  const Eigen::Vector3d db = world_from_b.rotation * bearing_b.normalized();
  const Eigen::Vector3d ca = world_from_a.translation;
  const Eigen::Vector3d cb = world_from_b.translation;
  if (std::atan2(da.cross(db).norm(), da.dot(db)) < min_angle_rad) return std::nullopt;
  // Minimise |ca + s da - (cb + u db)|^2 over the depths s, u.
  Eigen::Matrix2d a;
  a << da.dot(da), -da.dot(db), da.dot(db), -db.dot(db);
  const Eigen::Vector2d rhs((cb - ca).dot(da), (cb - ca).dot(db));
  const double det = a.determinant();
  if (std::abs(det) < 1e-12) return std::nullopt;
  const Eigen::Vector2d depths = a.inverse() * rhs;
  if (depths(0) <= 0 || depths(1) <= 0) return std::nullopt;
  return 0.5 * ((ca + depths(0) * da) + (cb + depths(1) * db));
}

Eigen::Matrix<double, 2, 3> tangentBasis(const Eigen::Vector3d& bearing) {
  const Eigen::Vector3d f = bearing.normalized();
  // Any vector not parallel to f seeds the basis.
  const Eigen::Vector3d seed =
      std::abs(f.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d b1 = f.cross(seed).normalized();
  const Eigen::Vector3d b2 = f.cross(b1);
  Eigen::Matrix<double, 2, 3> basis;
  basis.row(0) = b1.transpose();
  basis.row(1) = b2.transpose();
  return basis;
}

}  // namespace lookboth::vo
