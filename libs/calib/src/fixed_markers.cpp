#include "lookboth/calib/fixed_markers.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <algorithm>
#include <map>

#include "lookboth/core/error.h"
#include "lookboth/geometry/lie.h"

namespace lookboth {

std::string FixedMarkerOptions::check() const {
  if (!(default_translation_sigma_m > 0)) return "default_translation_sigma_m: must be > 0";
  if (!(shared_error_share >= 0 && shared_error_share <= 1)) {
    return "shared_error_share: must be in [0, 1]";
  }
  if (!(reject_chi2 > 0)) return "reject_chi2: must be > 0";
  return "";
}

namespace {

/// One detection's position in the world and its covariance from the
/// detection alone.
struct Sighting {
  Eigen::Vector3d p_in_world;
  Eigen::Vector3d p_in_camera;
  Eigen::Matrix3d covariance;
};

Eigen::Matrix3d detectionCovariance(const MarkerObservation& m, double default_sigma_m) {
  if (const auto covariance = markerCovariance(m)) return covariance->topLeftCorner<3, 3>();
  return Eigen::Matrix3d::Identity() * default_sigma_m * default_sigma_m;
}

/// The mean of one camera's sightings of one marker and its covariance, or
/// nothing when no sighting is left.
struct CameraMean {
  Eigen::Vector3d p_in_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_in_camera = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int detections = 0;
};

CameraMean weightedMean(const std::vector<Sighting>& sightings, const std::vector<bool>& kept) {
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), in_camera = Eigen::Vector3d::Zero();
  CameraMean mean;
  for (std::size_t i = 0; i < sightings.size(); ++i) {
    if (!kept[i]) continue;
    const Eigen::Matrix3d w = sightings[i].covariance.inverse();
    information += w;
    sum += w * sightings[i].p_in_world;
    in_camera += sightings[i].p_in_camera;
    ++mean.detections;
  }
  if (mean.detections == 0) return mean;
  mean.covariance = information.inverse();
  mean.p_in_world = mean.covariance * sum;
  mean.p_in_camera = in_camera / mean.detections;
  return mean;
}

Eigen::Vector3d componentwiseMedian(const std::vector<Sighting>& sightings) {
  Eigen::Vector3d median;
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> values;
    for (const Sighting& s : sightings) values.push_back(s.p_in_world[axis]);
    const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
    std::nth_element(values.begin(), middle, values.end());
    median[axis] = *middle;
  }
  return median;
}

CameraMean locateByCamera(const CameraRegistration& camera, const std::vector<Sighting>& sightings,
                          const FixedMarkerOptions& options) {
  // Gated about the median, which a wrong detection does not move.
  const Eigen::Vector3d centre = componentwiseMedian(sightings);
  std::vector<bool> kept(sightings.size(), true);
  for (std::size_t i = 0; i < sightings.size(); ++i) {
    const Eigen::Vector3d d = sightings[i].p_in_world - centre;
    if (d.dot(sightings[i].covariance.ldlt().solve(d)) > options.reject_chi2) kept[i] = false;
  }
  CameraMean mean = weightedMean(sightings, kept);
  if (mean.detections == 0) return mean;
  mean.covariance *= 1 + options.shared_error_share * (mean.detections - 1);
  if (camera.covariance) {
    // p = R_c p_in_camera + t_c, the camera perturbed as (t + dt, R Exp(dtheta)).
    Eigen::Matrix<double, 3, 6> j;
    j << Eigen::Matrix3d::Identity(),
        -camera.world_from_camera.rotation.toRotationMatrix() * skew(mean.p_in_camera);
    mean.covariance += j * *camera.covariance * j.transpose();
  }
  return mean;
}

}  // namespace

LocatedPoints locateFixedMarkers(const Registration& registration,
                                 const std::vector<MarkerObservation>& detections,
                                 int robot_marker_id, const FixedMarkerOptions& options) {
  if (const std::string why = options.check(); !why.empty()) throw Error("fixed markers: " + why);
  std::map<int, std::map<std::string, std::vector<Sighting>>> by_marker;
  for (const MarkerObservation& m : detections) {
    if (m.marker_id == robot_marker_id) continue;
    const CameraRegistration* camera = registration.findCamera(m.camera);
    if (camera == nullptr || camera->status == CameraStatus::kUnregistered) continue;
    const Eigen::Matrix3d r = camera->world_from_camera.rotation.toRotationMatrix();
    // Metres into the registration's units (a site frame aligned with its scale).
    const double scale = registration.world_frame.scale_from_registration;
    const Eigen::Vector3d p = scale * m.camera_from_marker.translation;
    by_marker[m.marker_id][m.camera].push_back(
        {camera->world_from_camera * p, p,
         scale * scale * r * detectionCovariance(m, options.default_translation_sigma_m) *
             r.transpose()});
  }
  LocatedPoints located;
  for (const auto& [id, cameras] : by_marker) {
    Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int count = 0;
    for (const auto& [label, sightings] : cameras) {
      const CameraMean mean = locateByCamera(*registration.findCamera(label), sightings, options);
      if (mean.detections == 0) continue;
      const Eigen::Matrix3d w = mean.covariance.inverse();
      information += w;
      sum += w * mean.p_in_world;
      count += mean.detections;
    }
    if (count == 0) continue;
    LocatedPoint point;
    point.covariance = information.inverse();
    point.p_in_world = point.covariance * sum;
    point.detections = count;
    located[fixedMarkerPointName(id)] = point;
  }
  return located;
}

}  // namespace lookboth
