#include "graph_edges.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>

#include "lookboth/geometry/lie.h"

namespace lookboth::export_detail {

Matrix6d composedCovariance(const Rigid3d& camera_from_marker, const Rigid3d& marker_from_node,
                            const Matrix6d& camera_from_marker_covariance) {
  // camera_from_marker perturbed as (R Exp(dtheta), t + dt) moves the
  // composition by dt' = dt - R [t_b]x dtheta and dtheta' = R_b^T dtheta.
  const Eigen::Matrix3d r = camera_from_marker.rotation.toRotationMatrix();
  Matrix6d jacobian = Matrix6d::Zero();
  jacobian.topLeftCorner<3, 3>().setIdentity();
  jacobian.topRightCorner<3, 3>() = -r * skew(marker_from_node.translation);
  jacobian.bottomRightCorner<3, 3>() = marker_from_node.rotation.toRotationMatrix().transpose();
  return jacobian * camera_from_marker_covariance * jacobian.transpose();
}

std::size_t nearestSample(const std::vector<StampedPose>& trajectory, TimeNs t) {
  const auto after = std::lower_bound(trajectory.begin(), trajectory.end(), t,
                                      [](const StampedPose& s, TimeNs x) { return s.t < x; });
  if (after == trajectory.begin()) return 0;
  if (after == trajectory.end()) return trajectory.size() - 1;
  const auto before = after - 1;
  const auto nearest = (t - before->t <= after->t - t) ? before : after;
  return static_cast<std::size_t>(nearest - trajectory.begin());
}

namespace {

/// The trajectory at `t` and its node nearest `t`, when `t` is inside it.
struct NodeAt {
  std::size_t node = 0;
  Rigid3d node_from_body;
  Rigid3d world_from_body;
};

std::optional<NodeAt> nodeAt(const Trajectory& trajectory, TimeNs t, TimeNs max_gap) {
  const InterpolationResult at = trajectory.interpolate(t, max_gap);
  if (!at.ok()) return std::nullopt;
  NodeAt result;
  result.node = nearestSample(trajectory.samples(), t);
  result.world_from_body = at.world_from_body;
  result.node_from_body =
      trajectory.samples()[result.node].world_from_body.inverse() * at.world_from_body;
  return result;
}

/// d(bearing)/d(pixel) by central differences through the model [1/px].
std::optional<Eigen::Matrix<double, 3, 2>> bearingJacobian(const Camera& camera,
                                                           const Eigen::Vector2d& pixel) {
  const double h = 0.5;
  Eigen::Matrix<double, 3, 2> jacobian;
  for (int axis = 0; axis < 2; ++axis) {
    const Eigen::Vector2d step = Eigen::Vector2d::Unit(axis) * h;
    const auto plus = camera.unproject(pixel + step);
    const auto minus = camera.unproject(pixel - step);
    if (!plus || !minus) return std::nullopt;
    jacobian.col(axis) = (*plus - *minus) / (2 * h);
  }
  return jacobian;
}

}  // namespace

std::optional<PoseEdge> markerEdge(const Trajectory& trajectory, const MarkerObservation& detection,
                                   TimeNs clock_offset_ns, const EdgeModel& model) {
  const std::optional<NodeAt> at =
      nodeAt(trajectory, detection.t - clock_offset_ns, model.max_gap_ns);
  if (!at) return std::nullopt;
  const Rigid3d marker_from_node = (at->node_from_body * model.fisheye_from_marker).inverse();
  PoseEdge edge;
  edge.node = at->node;
  edge.from_camera = true;
  edge.first_from_second = detection.camera_from_marker * marker_from_node;
  const Matrix6d detection_covariance =
      markerCovariance(detection).value_or(model.default_detection_covariance);
  edge.covariance =
      composedCovariance(detection.camera_from_marker, marker_from_node, detection_covariance);
  return edge;
}

std::optional<PoseEdge> blobEdge(const Trajectory& trajectory, const BlobAssociation& blob,
                                 const Camera& fisheye, const Rigid3d& world_from_camera,
                                 const EdgeModel& model) {
  const std::optional<NodeAt> at = nodeAt(trajectory, blob.t, model.max_gap_ns);
  if (!at) return std::nullopt;
  const Eigen::Vector2d pixel(blob.u, blob.v);
  const auto bearing = fisheye.unproject(pixel);
  const auto jacobian = bearingJacobian(fisheye, pixel);
  if (!bearing || !jacobian) return std::nullopt;
  const Eigen::Vector3d housing = world_from_camera * model.blob_in_camera;
  const double range = (at->world_from_body.inverse() * housing).norm();
  const Eigen::Matrix3d node_from_body = at->node_from_body.rotation.toRotationMatrix();
  // In the fisheye's frame: sideways the pixel's noise at that range, along
  // the ray (which a bearing does not measure) loose.
  const double sigma_px = model.blob_sigma_px;
  const Eigen::Matrix3d sideways =
      range * range * sigma_px * sigma_px * (*jacobian) * jacobian->transpose();
  const Eigen::Matrix3d along = model.blob_along_ray_sigma_m * model.blob_along_ray_sigma_m *
                                (*bearing) * bearing->transpose();
  PoseEdge edge;
  edge.node = at->node;
  const Rigid3d node_from_camera =
      trajectory.samples()[at->node].world_from_body.inverse() * world_from_camera;
  const Eigen::Vector3d housing_in_node = at->node_from_body * (range * (*bearing));
  edge.first_from_second =
      Rigid3d(node_from_camera.rotation,
              housing_in_node - node_from_camera.rotation * model.blob_in_camera);
  edge.covariance = Matrix6d::Zero();
  edge.covariance.topLeftCorner<3, 3>() =
      node_from_body * (sideways + along) * node_from_body.transpose();
  edge.covariance.bottomRightCorner<3, 3>() =
      Eigen::Matrix3d::Identity() * model.blob_rotation_sigma_rad * model.blob_rotation_sigma_rad;
  return edge;
}

std::vector<int> passSizes(const std::vector<TimeNs>& sorted_times, TimeNs max_gap_ns) {
  std::vector<int> sizes(sorted_times.size(), 0);
  std::size_t begin = 0;
  for (std::size_t i = 1; i <= sorted_times.size(); ++i) {
    if (i < sorted_times.size() && sorted_times[i] - sorted_times[i - 1] <= max_gap_ns) continue;
    for (std::size_t j = begin; j < i; ++j) sizes[j] = static_cast<int>(i - begin);
    begin = i;
  }
  return sizes;
}

PoseEdge fuseEdges(const std::vector<PoseEdge>& edges) {
  const PoseEdge& first = edges.front();
  if (edges.size() == 1) return first;
  Matrix6d information = Matrix6d::Zero();
  Eigen::Matrix<double, 6, 1> weighted = Eigen::Matrix<double, 6, 1>::Zero();
  for (const PoseEdge& e : edges) {
    const Matrix6d w = e.covariance.inverse();
    Eigen::Matrix<double, 6, 1> difference;
    difference.head<3>() = e.first_from_second.translation - first.first_from_second.translation;
    difference.tail<3>() = so3Log(Eigen::Quaterniond(first.first_from_second.rotation.conjugate() *
                                                     e.first_from_second.rotation));
    information += w;
    weighted += w * difference;
  }
  PoseEdge fused = first;
  fused.covariance = information.inverse();
  fused.covariance = 0.5 * (fused.covariance + fused.covariance.transpose()).eval();
  const Eigen::Matrix<double, 6, 1> step = fused.covariance * weighted;
  fused.first_from_second = Rigid3d(
      (first.first_from_second.rotation * so3Exp(Eigen::Vector3d(step.tail<3>()))).normalized(),
      first.first_from_second.translation + step.head<3>());
  return fused;
}

double edgeChi2(const PoseEdge& edge, const Rigid3d& first_from_second) {
  Eigen::Matrix<double, 6, 1> residual;
  residual.head<3>() = first_from_second.translation - edge.first_from_second.translation;
  residual.tail<3>() = so3Log(
      Eigen::Quaterniond(edge.first_from_second.rotation.conjugate() * first_from_second.rotation));
  return residual.dot(edge.covariance.ldlt().solve(residual));
}

}  // namespace lookboth::export_detail
