// Fixed markers located by registered cameras: exact detections give the
// marker's position exactly; noisy ones (detections and camera poses drawn
// from their covariances) give errors the predicted covariance accounts for
// (NEES per degree of freedom near 1).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "lookboth/calib/fixed_markers.h"
#include "lookboth/core/error.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"

namespace lookboth {
namespace {

CameraRegistration camera(const std::string& label, const Eigen::Vector3d& position,
                          const Eigen::Vector3d& rotation_vector) {
  CameraRegistration c;
  c.label = label;
  c.status = CameraStatus::kRegistered;
  // Looking down (x axis flipped), then tilted.
  c.world_from_camera =
      Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX())) *
                  so3Exp(rotation_vector),
              position);
  Matrix6d covariance = Matrix6d::Zero();
  covariance.diagonal() << 4e-6, 5e-6, 9e-6, 1e-6, 2e-6, 1.5e-6;  // mm and 0.06-0.08 deg
  c.covariance = covariance;
  return c;
}

struct Site {
  Registration reg;
  Rigid3d world_from_marker = Rigid3d(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ())), {1.5, 2.0, 0.0});
  Site() {
    reg.cameras = {camera("cam_a", {1.0, 1.2, 3.0}, {0.1, -0.05, 0.3}),
                   camera("cam_b", {2.6, 2.4, 3.2}, {-0.2, 0.1, 1.1}),
                   camera("cam_c", {9.0, 9.0, 3.0}, {0, 0, 0})};
    reg.cameras[2].status = CameraStatus::kUnregistered;
  }
  /// A detection's information: 1 mm across the line of sight, 5 mm along
  /// it in the camera's z, 3 deg of tilt.
  static Matrix6d information() {
    Matrix6d info = Matrix6d::Zero();
    info.diagonal() << 1e6, 1e6, 4e4, 365, 365, 3e4;
    return info;
  }
  MarkerObservation detection(const CameraRegistration& c, int id) const {
    MarkerObservation m;
    m.camera = c.label;
    m.marker_id = id;
    m.camera_from_marker = c.world_from_camera.inverse() * world_from_marker;
    m.information = information();
    return m;
  }
};

TEST(FixedMarkers, ExactDetectionsGiveTheMarkersPosition) {
  const Site site;
  std::vector<MarkerObservation> detections;
  for (int k = 0; k < 5; ++k) {
    for (const CameraRegistration& c : site.reg.cameras)
      detections.push_back(site.detection(c, 12));
    detections.push_back(site.detection(site.reg.cameras[0], 3));  // the robot's marker
  }
  const LocatedPoints located = locateFixedMarkers(site.reg, detections, 3);
  ASSERT_EQ(located.size(), 1u);
  const LocatedPoint& point = located.at("marker:12");
  EXPECT_LT((point.p_in_world - site.world_from_marker.translation).norm(), 1e-9);
  EXPECT_EQ(point.detections, 10);  // the unregistered camera's are not used
  EXPECT_GT(point.covariance.trace(), 0);
}

TEST(FixedMarkers, ADetectionFarFromItsCamerasOthersIsLeftOut) {
  const Site site;
  std::vector<MarkerObservation> detections;
  for (int k = 0; k < 8; ++k) detections.push_back(site.detection(site.reg.cameras[0], 12));
  MarkerObservation wrong = site.detection(site.reg.cameras[0], 12);
  wrong.camera_from_marker.translation += Eigen::Vector3d(0.3, 0, 0);
  detections.push_back(wrong);
  const LocatedPoint point = locateFixedMarkers(site.reg, detections, 3).at("marker:12");
  EXPECT_LT((point.p_in_world - site.world_from_marker.translation).norm(), 1e-9);
  EXPECT_EQ(point.detections, 8);
}

// Detections drawn from their information, camera poses from their
// covariances, no shared error: the mean NEES per dof over the trials is
// near 1 (3 dof x 400 trials: its standard deviation is about 0.04).
TEST(FixedMarkers, TheCovariancePredictsTheError) {
  const Site site;
  std::mt19937 rng(7);
  std::normal_distribution<double> n(0.0, 1.0);
  auto draw = [&](const Matrix6d& covariance) {
    const Eigen::LLT<Matrix6d> llt(covariance);
    return Eigen::Matrix<double, 6, 1>(llt.matrixL() * drawVector<6>([&] { return n(rng); }));
  };
  auto moved = [](const Rigid3d& pose, const Eigen::Matrix<double, 6, 1>& d) {
    return Rigid3d(pose.rotation * so3Exp(Eigen::Vector3d(d.tail<3>())),
                   pose.translation + d.head<3>());
  };
  FixedMarkerOptions options;
  options.shared_error_share = 0;
  const int trials = 400;
  double nees = 0;
  for (int trial = 0; trial < trials; ++trial) {
    Registration drawn = site.reg;
    std::vector<MarkerObservation> detections;
    for (int c = 0; c < 2; ++c) {
      // The truth is the registered pose moved by the camera's error.
      const CameraRegistration& registered = site.reg.cameras[static_cast<std::size_t>(c)];
      CameraRegistration truth = registered;
      truth.world_from_camera = moved(registered.world_from_camera, draw(*registered.covariance));
      for (int k = 0; k < 20; ++k) {
        MarkerObservation m = site.detection(truth, 12);
        m.camera_from_marker =
            moved(m.camera_from_marker, draw(Matrix6d(Site::information().inverse())));
        detections.push_back(m);
      }
    }
    const LocatedPoint point = locateFixedMarkers(drawn, detections, 3, options).at("marker:12");
    const Eigen::Vector3d error = point.p_in_world - site.world_from_marker.translation;
    nees += error.dot(point.covariance.inverse() * error) / 3;
  }
  nees /= trials;
  std::cout << "fixed marker: mean NEES per dof " << nees << " over " << trials << " trials\n";
  EXPECT_GT(nees, 0.85);
  EXPECT_LT(nees, 1.15);
}

TEST(FixedMarkers, OptionsAreChecked) {
  FixedMarkerOptions options;
  options.shared_error_share = 1.5;
  EXPECT_NE(options.check().find("shared_error_share"), std::string::npos);
  EXPECT_THROW(locateFixedMarkers(Registration{}, {}, 0, options), Error);
}

}  // namespace
}  // namespace lookboth
