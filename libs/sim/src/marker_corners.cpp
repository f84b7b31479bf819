#include "lookboth/sim/marker_corners.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/pose_perturbation.h"

namespace lookboth::sim {
namespace {

using Vector8d = Eigen::Matrix<double, 8, 1>;
using Matrix86d = Eigen::Matrix<double, 8, 6>;

/// The pose moved by [dt; dtheta]: t + dt, R Exp(dtheta) (MarkerObservation's perturbation).
Rigid3d perturbed(const Rigid3d& pose, const Vector6d& delta) {
  const Eigen::Vector3d dtheta = delta.tail<3>();
  return Rigid3d((pose.rotation * so3Exp(dtheta)).normalized(), pose.translation + delta.head<3>());
}

/// Projections minus observed corners [px]; nullopt when a corner does not project.
std::optional<Vector8d> residuals(const Camera& camera, const Rigid3d& camera_from_marker,
                                  const std::array<Eigen::Vector3d, 4>& corners_in_marker,
                                  const std::array<Eigen::Vector2d, 4>& corners_px) {
  Vector8d r;
  for (size_t k = 0; k < 4; ++k) {
    const auto pixel = camera.project(camera_from_marker * corners_in_marker[k]);
    if (!pixel) return std::nullopt;
    r.segment<2>(static_cast<Eigen::Index>(2 * k)) = *pixel - corners_px[k];
  }
  return r;
}

/// d residuals / d [dt; dtheta] by central differences (the camera models
/// have no analytic derivative; steps of 1e-6 m and 1e-6 rad leave errors
/// of ~1e-7 px/m and ~1e-7 px/rad, far below what the information needs).
std::optional<Matrix86d> jacobian(const Camera& camera, const Rigid3d& camera_from_marker,
                                  const std::array<Eigen::Vector3d, 4>& corners_in_marker,
                                  const std::array<Eigen::Vector2d, 4>& corners_px) {
  Matrix86d jac;
  for (int j = 0; j < 6; ++j) {
    const double h = 1e-6;
    Vector6d delta = Vector6d::Zero();
    delta(j) = h;
    const auto plus =
        residuals(camera, perturbed(camera_from_marker, delta), corners_in_marker, corners_px);
    const auto minus =
        residuals(camera, perturbed(camera_from_marker, -delta), corners_in_marker, corners_px);
    if (!plus || !minus) return std::nullopt;
    jac.col(j) = (*plus - *minus) / (2 * h);
  }
  return jac;
}

}  // namespace

std::array<Eigen::Vector3d, 4> markerCornersInMarker(double size_m) {
  const double h = 0.5 * size_m;
  return {Eigen::Vector3d(-h, h, 0), Eigen::Vector3d(h, h, 0), Eigen::Vector3d(h, -h, 0),
          Eigen::Vector3d(-h, -h, 0)};
}

std::optional<CornerPose> poseFromCorners(const Camera& camera, double size_m,
                                          const std::array<Eigen::Vector2d, 4>& corners_px,
                                          const Rigid3d& initial, double corner_sigma_px) {
  const auto object = markerCornersInMarker(size_m);
  Rigid3d pose = initial;
  // Converged when the step moves the corners by less than 1e-9 px. Along
  // the tilt of a small, nearly fronto-parallel marker the cost is so flat
  // that Gauss-Newton converges only linearly there (a ratio ~0.7 per step
  // with 0.3 px noise on a 70 px marker), hence the generous iteration limit.
  bool converged = false;
  double step_px = 0;
  for (int iteration = 0; iteration < 200 && !converged; ++iteration) {
    const auto r = residuals(camera, pose, object, corners_px);
    const auto jac = jacobian(camera, pose, object, corners_px);
    if (!r || !jac) return std::nullopt;
    const Vector6d delta = -(jac->transpose() * *jac).ldlt().solve(jac->transpose() * *r);
    if (!delta.allFinite()) return std::nullopt;
    pose = perturbed(pose, delta);
    step_px = (*jac * delta).norm();
    converged = step_px < 1e-9 || r->isZero(0.0);
  }
  // Still moving after 200 steps: accepted when the steps are 1e-3 of the
  // corner noise (the pose is then far closer to the minimum than its
  // uncertainty), else diverging or stuck between the two tilt solutions.
  if (!converged && step_px > 1e-3 * corner_sigma_px) return std::nullopt;
  const auto r = residuals(camera, pose, object, corners_px);
  const auto jac = jacobian(camera, pose, object, corners_px);
  if (!r || !jac) return std::nullopt;
  CornerPose result;
  result.camera_from_marker = pose;
  result.information = jac->transpose() * *jac / (corner_sigma_px * corner_sigma_px);
  result.reprojection_rms_px = std::sqrt(r->squaredNorm() / 4);
  return result;
}

std::optional<MarkerObservation> markerFromNoisyCorners(const Camera& camera,
                                                        const Rigid3d& camera_from_marker,
                                                        const MarkerSpec& marker,
                                                        double corner_sigma_px, std::mt19937& rng) {
  const auto object = markerCornersInMarker(marker.size_m);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  std::array<Eigen::Vector2d, 4> corners;
  for (size_t k = 0; k < 4; ++k) {
    const auto pixel = camera.project(camera_from_marker * object[k]);
    if (!pixel) return std::nullopt;
    const double n_u = gaussian(rng);
    const double n_v = gaussian(rng);
    corners[k] = *pixel + corner_sigma_px * Eigen::Vector2d(n_u, n_v);
  }
  const auto pose = poseFromCorners(camera, marker.size_m, corners, camera_from_marker,
                                    std::max(corner_sigma_px, 1e-6));
  if (!pose) return std::nullopt;
  MarkerObservation obs;
  obs.marker_id = marker.id;
  obs.camera_from_marker = pose->camera_from_marker;
  obs.information = pose->information;
  obs.corners_px.assign(corners.begin(), corners.end());
  obs.corner_sigma_px = corner_sigma_px;
  return obs;
}

void addPassBias(const std::vector<MarkerObservation*>& pass, double share, std::mt19937& rng,
                 const Camera* camera, double marker_size_m) {
  if (pass.empty() || !(share > 0)) return;
  Matrix6d information = Matrix6d::Zero();
  for (const MarkerObservation* m : pass) {
    information += informationOnCameraPose(m->camera_from_marker, m->information);
  }
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 * (information + information.transpose()));
  const double scale = share * static_cast<double>(pass.size());
  std::normal_distribution<double> gaussian(0.0, 1.0);
  Vector6d delta = Vector6d::Zero();
  for (int k = 0; k < 6; ++k) {
    const double draw = gaussian(rng);
    const double value = eig.eigenvalues()[k];
    if (value > 0) delta += std::sqrt(scale / value) * draw * eig.eigenvectors().col(k);
  }
  const Eigen::Quaterniond turn = so3Exp(Eigen::Vector3d(delta.tail<3>()));
  const auto corners = markerCornersInMarker(marker_size_m);
  for (MarkerObservation* m : pass) {
    const Rigid3d before = m->camera_from_marker;
    m->camera_from_marker.rotation = (turn * before.rotation).normalized();
    m->camera_from_marker.translation = turn * before.translation + delta.head<3>();
    for (std::size_t k = 0; camera != nullptr && k < m->corners_px.size() && k < 4; ++k) {
      const auto from = camera->project(before * corners[k]);
      const auto to = camera->project(m->camera_from_marker * corners[k]);
      if (from && to) m->corners_px[k] += *to - *from;
    }
  }
}

}  // namespace lookboth::sim
