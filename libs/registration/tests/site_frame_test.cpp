// Floor and site frames: ground truth -> noise -> solve -> bound, and the
// predicted uncertainty of the site alignment against its measured error.
#include "lookboth/registration/site_frame.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>

#include "lookboth/core/error.h"
#include "lookboth/core/test_seed.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"
#include "lookboth/geometry/time.h"

namespace lookboth {
namespace {

Rigid3d someTransform() {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.5, 1.0).normalized()));
  return Rigid3d(q, Eigen::Vector3d(12.0, -3.5, 1.25));
}

/// A registration made in a site frame (floor at z = 0, cameras at 3 m,
/// the robot's fisheye at 0.4 m on a 10 m x 6 m loop), then expressed in
/// the frame `world_from_site` maps into.
Registration siteRegistration(const Rigid3d& world_from_site) {
  Registration reg;
  for (int k = 0; k < 200; ++k) {
    const double a = 2 * M_PI * k / 200;
    const Rigid3d fisheye(
        Eigen::Quaterniond(Eigen::AngleAxisd(a + M_PI / 2, Eigen::Vector3d::UnitZ())),
        Eigen::Vector3d(5 + 5 * std::cos(a), 3 + 3 * std::sin(a), 0.4));
    reg.trajectory.push_back({k * 100000000LL, world_from_site * fisheye});
  }
  const Eigen::Quaterniond down(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));
  for (int i = 0; i < 6; ++i) {
    CameraRegistration c;
    c.label = "cam0" + std::to_string(i);
    c.status = CameraStatus::kRegistered;
    c.world_from_camera =
        world_from_site * Rigid3d(down, Eigen::Vector3d(1.0 + 2 * i, i % 2 ? 6.0 : 0.5, 3.0));
    Matrix6d covariance = Matrix6d::Identity() * 1e-6;
    covariance(0, 4) = covariance(4, 0) = 2e-7;
    c.covariance = covariance;
    c.aligned_position_covariance = Eigen::Matrix3d::Identity() * 4e-6;
    reg.cameras.push_back(c);
  }
  return reg;
}

double angleDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return Eigen::AngleAxisd(a * b.conjugate()).angle() * 180 / M_PI;
}

TEST(FloorFrame, RecoversTheFloorOfATiltedRegistration) {
  const Rigid3d world_from_site = someTransform();
  const Registration reg = siteRegistration(world_from_site);
  const FloorFit fit = fitFloor(reg);
  // The floor frame's z is the site's up, its origin on the fisheye's plane.
  const Eigen::Vector3d z_in_site =
      world_from_site.rotation.conjugate() *
      (fit.floor_from_world.inverse().rotation * Eigen::Vector3d::UnitZ());
  EXPECT_LT((z_in_site - Eigen::Vector3d::UnitZ()).norm(), 1e-9);
  for (const StampedPose& p : reg.trajectory) {
    EXPECT_NEAR((fit.floor_from_world * p.world_from_body.translation).z(), 0.0, 1e-9);
  }
  EXPECT_NEAR(fit.flatness_rms_m, 0.0, 1e-9);
  const Eigen::Vector3d site_z_in_world = world_from_site.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(fit.tilt_deg, std::acos(site_z_in_world.z()) * 180 / M_PI, 1e-9);
  EXPECT_NEAR((fit.floor_from_world * reg.trajectory.front().world_from_body.translation).norm(),
              0.0, 1e-9);
  // Cameras above the floor.
  EXPECT_NEAR((fit.floor_from_world * reg.cameras[0].world_from_camera.translation).z(), 2.6, 1e-9);
}

TEST(FloorFrame, AStraightDriveIsAnError) {
  Registration reg = siteRegistration(Rigid3d());
  for (std::size_t k = 0; k < reg.trajectory.size(); ++k) {
    reg.trajectory[k].world_from_body.translation = Eigen::Vector3d(0.05 * k, 0.001 * (k % 3), 0.4);
  }
  try {
    fitFloor(reg);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("straight line"), std::string::npos) << e.what();
  }
}

std::vector<ControlPoint> controlPoints(const Registration& site, double sigma, int count) {
  std::vector<ControlPoint> points;
  for (int i = 0; i < count; ++i) {
    points.push_back(
        {site.cameras[i].label, site.cameras[i].world_from_camera.translation, sigma, i + 2});
  }
  return points;
}

TEST(SiteFrame, NoiseFreeControlPointsGiveTheSiteFrame) {
  const Rigid3d world_from_site = someTransform();
  const Registration site = siteRegistration(Rigid3d());
  const Registration reg = siteRegistration(world_from_site);
  const SiteAlignment aligned =
      alignToControlPoints(reg, controlPoints(site, 0.005, 4), "site.csv");
  const Rigid3d expected = world_from_site.inverse();
  EXPECT_LT((aligned.site_from_world.translation - expected.translation).norm(), 1e-9);
  EXPECT_LT(angleDeg(aligned.site_from_world.rotation, expected.rotation), 1e-7);
  EXPECT_LT(aligned.rms_m, 1e-9);
}

// The NEES tests score every Gaussian draw: the check that names an
// inconsistent point (99.9 % per point, AnInconsistentPointIsNamed) would
// refuse about 1 in 200 of their 5-6 point draws, and a draw left out would
// bias the NEES low.
SiteAlignmentOptions withoutConsistencyCheck(SiteAlignmentOptions options) {
  options.max_normalized_residual = std::numeric_limits<double>::infinity();
  return options;
}

TEST(SiteFrame, PredictedUncertaintyMatchesTheErrors) {
  const Rigid3d world_from_site = someTransform();
  const Registration site = siteRegistration(Rigid3d());
  Registration reg = siteRegistration(world_from_site);
  for (CameraRegistration& c : reg.cameras) c.covariance.reset();  // the points' sigma alone
  const SiteAlignmentOptions options = withoutConsistencyCheck({});
  std::mt19937 rng(testSeed(7));
  std::normal_distribution<double> noise(0.0, 0.005);
  double nees = 0;
  const int trials = 400;
  for (int trial = 0; trial < trials; ++trial) {
    std::vector<ControlPoint> points = controlPoints(site, 0.005, 5);
    for (ControlPoint& p : points) p.p_in_site += drawVector<3>([&] { return noise(rng); });
    const SiteAlignment aligned = alignToControlPoints(reg, points, "site.csv", options);
    // The error as the covariance's perturbation: truth = Exp(dtheta) estimate + dt.
    const Rigid3d truth = world_from_site.inverse();
    const Eigen::Quaterniond dq = truth.rotation * aligned.site_from_world.rotation.conjugate();
    const Eigen::Vector3d dtheta = Eigen::AngleAxisd(dq).angle() * Eigen::AngleAxisd(dq).axis();
    Eigen::Matrix<double, 6, 1> e;
    e << truth.translation - dq * aligned.site_from_world.translation, dtheta;
    nees += e.dot(aligned.covariance.topLeftCorner<6, 6>().inverse() * e);
  }
  const double per_dof = nees / trials / 6;
  std::cout << "site frame: mean NEES/dof over " << trials << " trials " << per_dof << "\n";
  EXPECT_GT(per_dof, 0.85);
  EXPECT_LT(per_dof, 1.15);
}

TEST(SiteFrame, AnInconsistentPointIsNamed) {
  const Registration site = siteRegistration(Rigid3d());
  const Registration reg = siteRegistration(someTransform());
  std::vector<ControlPoint> points = controlPoints(site, 0.005, 5);
  points[2].p_in_site.x() += 0.10;
  try {
    alignToControlPoints(reg, points, "site.csv");
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'cam02'"), std::string::npos) << what;
    EXPECT_NE(what.find("site.csv:4"), std::string::npos) << what;
  }
  points[2].name = "cam99";
  EXPECT_THROW(alignToControlPoints(reg, points, "site.csv"), Error);
}

TEST(SiteFrame, ReexpressedRegistrationKeepsItsGeometry) {
  const Registration reg = siteRegistration(someTransform());
  const Rigid3d t = someTransform().inverse();
  WorldFrame frame;
  frame.name = "site";
  const Registration out = reexpressRegistration(reg, t, std::nullopt, frame);
  EXPECT_EQ(out.world_frame.name, "site");
  ASSERT_TRUE(out.world_frame.from_registration);
  const Rigid3d relative_before =
      reg.cameras[0].world_from_camera.inverse() * reg.cameras[3].world_from_camera;
  const Rigid3d relative_after =
      out.cameras[0].world_from_camera.inverse() * out.cameras[3].world_from_camera;
  EXPECT_LT((relative_before.translation - relative_after.translation).norm(), 1e-12);
  // The position covariance turns with the frame; the rotation's stays (right perturbation).
  const Eigen::Matrix3d r = t.rotation.toRotationMatrix();
  const Matrix6d& before = *reg.cameras[0].covariance;
  const Matrix6d& after = *out.cameras[0].covariance;
  EXPECT_LT((after.topLeftCorner<3, 3>() - r * before.topLeftCorner<3, 3>() * r.transpose()).norm(),
            1e-18);
  EXPECT_LT((after.bottomRightCorner<3, 3>() - before.bottomRightCorner<3, 3>()).norm(), 1e-18);
  // And back.
  const Registration back = reexpressRegistration(out, t.inverse(), std::nullopt, WorldFrame{});
  EXPECT_LT(
      (back.cameras[4].world_from_camera.translation - reg.cameras[4].world_from_camera.translation)
          .norm(),
      1e-12);
  EXPECT_LT((*back.cameras[4].covariance - *reg.cameras[4].covariance).norm(), 1e-18);
  EXPECT_LT(back.world_frame.from_registration->translation.norm(), 1e-12);
}

TEST(SiteFrame, ControlPointFilesAreCheckedByLine) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                     ("control_points_" + std::to_string(getpid()) + ".csv");
  auto expectError = [&](const std::string& text, const std::string& part) {
    std::ofstream(path) << text;
    try {
      readControlPoints(path);
      ADD_FAILURE() << "no error for: " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  expectError("name,x,y,sigma_m\n", "'z'");
  expectError("name,x,y,z,sigma_m\ncam00,1,2,x3,0.01\n", ":2");
  expectError("name,x,y,z,sigma_m\ncam00,1,2,3,0\n", "sigma_m");
  expectError("name,x,y,z,sigma_m\ncam00,1,2,3,0.1\ncam00,1,2,3,0.1\n", "already on line 2");
  std::ofstream(path)
      << "\xEF\xBB\xBF# surveyed\nname, x, y, z, sigma_m\ncam00, 1.5, -2, 3.25, 0.005\n";
  const std::vector<ControlPoint> points = readControlPoints(path);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0].p_in_site, Eigen::Vector3d(1.5, -2, 3.25));
  EXPECT_EQ(points[0].line, 3);
  std::filesystem::remove(path);
}

// A registration whose scale is off: the same site expressed in a frame
// where every length is `scale` times the truth.
Registration scaledRegistration(const Rigid3d& world_from_site, double scale) {
  const Sim3d scaled(scale, world_from_site.rotation, world_from_site.translation);
  return reexpressRegistration(siteRegistration(Rigid3d()), scaled, std::nullopt, WorldFrame{});
}

TEST(SiteFrame, NoiseFreeControlPointsGiveTheScaleWithScale) {
  const Rigid3d world_from_site = someTransform();
  const Registration site = siteRegistration(Rigid3d());
  const Registration reg = scaledRegistration(world_from_site, 1.02);
  SiteAlignmentOptions options;
  options.with_scale = true;
  const SiteAlignment aligned =
      alignToControlPoints(reg, controlPoints(site, 0.005, 5), "site.csv", options);
  const Sim3d expected =
      Sim3d(1.02, world_from_site.rotation, world_from_site.translation).inverse();
  EXPECT_NEAR(aligned.scale, expected.scale, 1e-9);
  EXPECT_LT((aligned.site_from_world.translation - expected.translation).norm(), 1e-9);
  EXPECT_LT(angleDeg(aligned.site_from_world.rotation, expected.rotation), 1e-7);
  EXPECT_LT(aligned.rms_m, 1e-9);
  // Rigid, the same points leave the 2 % in the residuals.
  const SiteAlignment rigid =
      alignToControlPoints(reg, controlPoints(site, 0.05, 5), "site.csv", SiteAlignmentOptions{});
  EXPECT_EQ(rigid.scale, 1.0);
  EXPECT_GT(rigid.rms_m, 0.02);
}

TEST(SiteFrame, TheScalesUncertaintyMatchesItsErrors) {
  const Rigid3d world_from_site = someTransform();
  const Registration site = siteRegistration(Rigid3d());
  Registration reg = scaledRegistration(world_from_site, 0.97);
  for (CameraRegistration& c : reg.cameras) c.covariance.reset();  // the points' sigma alone
  SiteAlignmentOptions options;
  options.with_scale = true;
  options = withoutConsistencyCheck(options);
  const Sim3d truth = Sim3d(0.97, world_from_site.rotation, world_from_site.translation).inverse();
  std::mt19937 rng(testSeed(11));
  std::normal_distribution<double> noise(0.0, 0.005);
  double nees = 0;
  const int trials = 400;
  for (int trial = 0; trial < trials; ++trial) {
    std::vector<ControlPoint> points = controlPoints(site, 0.005, 6);
    for (ControlPoint& p : points) p.p_in_site += drawVector<3>([&] { return noise(rng); });
    const SiteAlignment a = alignToControlPoints(reg, points, "site.csv", options);
    // truth = (1 + ds) Exp(dtheta) estimate + dt, over the estimate's points.
    const Eigen::Quaterniond dq = truth.rotation * a.site_from_world.rotation.conjugate();
    const double ds = truth.scale / a.scale - 1;
    Eigen::Matrix<double, 7, 1> e;
    e << truth.translation - (1 + ds) * (dq * a.site_from_world.translation),
        Eigen::AngleAxisd(dq).angle() * Eigen::AngleAxisd(dq).axis(), ds;
    nees += e.dot(a.covariance.inverse() * e);
  }
  const double per_dof = nees / trials / 7;
  std::cout << "site frame with scale: mean NEES/dof over " << trials << " trials " << per_dof
            << "\n";
  EXPECT_GT(per_dof, 0.85);
  EXPECT_LT(per_dof, 1.15);
}

TEST(SiteFrame, TheRobotsDockIsAControlPoint) {
  const Rigid3d world_from_site = someTransform();
  const Registration site = siteRegistration(Rigid3d());
  const Registration reg = siteRegistration(world_from_site);
  std::vector<ControlPoint> points = controlPoints(site, 0.005, 2);
  points.push_back({"@start", site.trajectory.front().world_from_body.translation, 0.005, 4});
  points.push_back({"@end", site.trajectory.back().world_from_body.translation, 0.005, 5});
  // Half-way between two samples: the interpolated position.
  const Eigen::Vector3d between = 0.5 * (site.trajectory[50].world_from_body.translation +
                                         site.trajectory[51].world_from_body.translation);
  points.push_back({"@" + formatSeconds(site.trajectory[50].t + 50'000'000), between, 0.005, 6});
  const SiteAlignment aligned = alignToControlPoints(reg, points, "site.csv");
  const Rigid3d expected = world_from_site.inverse();
  EXPECT_LT((aligned.site_from_world.translation - expected.translation).norm(), 1e-6);
  EXPECT_LT(angleDeg(aligned.site_from_world.rotation, expected.rotation), 1e-5);
  EXPECT_LT(aligned.rms_m, 1e-3);  // the chord between samples is not the arc: < 1 mm
  for (const char* bad : {"@999999", "@soon"}) {
    std::vector<ControlPoint> wrong = points;
    wrong.back().name = bad;
    try {
      alignToControlPoints(reg, wrong, "site.csv");
      FAIL() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("site.csv:6"), std::string::npos) << e.what();
    }
  }
}

// Markers on the floor, located in the registration's frame: their
// surveyed positions set the site frame like cameras'; a marker no camera
// located is an error naming its line; the marker's own variance weighs it.
TEST(SiteFrame, FixedMarkersAreControlPoints) {
  const Rigid3d world_from_site = someTransform();
  const Registration reg = siteRegistration(world_from_site);
  std::vector<ControlPoint> points;
  LocatedPoints located;
  const std::vector<Eigen::Vector3d> floor = {{1, 1, 0}, {8, 1.5, 0}, {7.5, 5, 0}, {2, 5.5, 0}};
  for (std::size_t i = 0; i < floor.size(); ++i) {
    const std::string name = fixedMarkerPointName(20 + static_cast<int>(i));
    points.push_back({name, floor[i], 0.005, static_cast<int>(i) + 2});
    located[name] = {world_from_site * floor[i], Eigen::Matrix3d::Identity() * 9e-6, 40};
  }
  EXPECT_TRUE(namesFixedMarker("marker:20"));
  EXPECT_FALSE(namesFixedMarker("cam_marker:20"));
  const SiteAlignment aligned = alignToControlPoints(reg, points, "site.csv", {}, located);
  const Rigid3d expected = world_from_site.inverse();
  EXPECT_LT((aligned.site_from_world.translation - expected.translation).norm(), 1e-9);
  EXPECT_LT(angleDeg(aligned.site_from_world.rotation, expected.rotation), 1e-7);
  // Each residual in sigmas of sqrt(5 mm^2 + 3 mm^2): 1 cm off is 1.71.
  std::vector<ControlPoint> moved = points;
  moved[0].p_in_site.z() += 0.01;
  const SiteAlignment off = alignToControlPoints(
      reg, moved, "site.csv", withoutConsistencyCheck(SiteAlignmentOptions{}), located);
  EXPECT_NEAR(off.residuals[0].normalized,
              off.residuals[0].residual_m.norm() / std::sqrt(25e-6 + 9e-6), 1e-12);
  located.erase("marker:22");
  try {
    alignToControlPoints(reg, points, "site.csv", {}, located);
    FAIL() << "a marker no camera located was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("site.csv:4"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'marker:22'"), std::string::npos) << e.what();
  }
}

TEST(SiteFrame, TheFrameIsSavedAndReadBack) {
  Registration reg = siteRegistration(someTransform());
  reg.dataset = "/data/x.rawlog";
  reg.pipeline = {"joint"};
  const Registration out =
      reexpressRegistration(reg, someTransform().inverse(), std::nullopt,
                            WorldFrame{"floor", "the floor", std::nullopt, 1.0, {}});
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("site_frame_io_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  saveRegistration(out, dir);
  const Registration back = loadRegistration(dir);
  EXPECT_EQ(back.world_frame.name, "floor");
  EXPECT_EQ(back.world_frame.scale_from_registration, 1.0);
  EXPECT_EQ(back.world_frame.description, "the floor");
  ASSERT_TRUE(back.world_frame.from_registration);
  EXPECT_LT((back.world_frame.from_registration->translation -
             out.world_frame.from_registration->translation)
                .norm(),
            1e-12);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace lookboth
