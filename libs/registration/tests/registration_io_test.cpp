#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/geometry/random.h"
#include "lookboth/registration/registration.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

Rigid3d randomPose(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const Eigen::Vector4d wxyz = drawVector<4>([&] { return n(rng); });
  const Eigen::Quaterniond q = Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]).normalized();
  return Rigid3d(q, drawVector<3>([&] { return n(rng); }) * 5.0);
}

Matrix6d randomCovariance(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1e-3);
  Matrix6d a;
  for (int i = 0; i < 36; ++i) a(i) = n(rng);
  return a * a.transpose();
}

Registration sampleRegistration() {
  std::mt19937 rng(7);
  Registration reg;
  reg.dataset = "/abs/path/of/dataset.rawlog";
  reg.created = "2026-11-22T12:00:00Z";
  reg.versions = {
      {"lookboth", "0.1.0"}, {"mrpt", "2.5.8"}, {"opencv", "4.6.0"}, {"ceres", "2.1.0"}};
  reg.pipeline = {"associate", "motion_calibration", "look_down", "look_up"};
  reg.trajectory_mode = TrajectoryMode::kVisual;
  reg.trajectory_label = "vo";
  reg.scale = 1.2345678901234567;
  reg.scale_sigma = 1.5e-3;
  reg.fisheye_from_marker = randomPose(rng);
  reg.fisheye_from_marker_covariance = randomCovariance(rng);
  reg.fisheye_from_marker_determined = {true, true, false, false, false, true};
  reg.fisheye_from_marker_prior = "marker height above fisheye from config: 0.05 m";

  CameraRegistration a;
  a.label = "cam01";
  a.status = CameraStatus::kRegistered;
  a.world_from_camera = randomPose(rng);
  a.stage_poses["look_down"] = randomPose(rng);
  a.stage_poses["look_up"] = a.world_from_camera;
  a.covariance = randomCovariance(rng);
  a.aligned_position_covariance = Eigen::Matrix3d(randomCovariance(rng).topLeftCorner<3, 3>());
  a.detections = {120, 110, 10, 0};
  a.residuals = ResidualStats{0.004, 0.1};
  a.reprojection = ReprojectionStats{300, 2.1, 0.9};
  a.clock_offset = ClockOffsetEstimate{-150123456, 0.37, true};
  CameraRegistration b;
  b.label = "cam02";
  b.status = CameraStatus::kSuspect;
  b.reason = "detections disagree: 40 % rejected";
  b.world_from_camera = randomPose(rng);
  b.detections = {50, 30, 20, 3};
  b.residuals = ResidualStats{0.2, 3.5};
  b.warnings = {"few detections", "a \"quoted\" word: and a colon"};
  CameraRegistration c;
  c.label = "cam03";
  c.status = CameraStatus::kUnregistered;
  c.reason = "never detected";
  reg.cameras = {a, b, c};
  reg.reprojection = ReprojectionStats{3000, 2.3, 1.1, "joint"};
  reg.observability.message = "the vertical offset is not determined by planar motion";
  reg.observability.eigenvalues = {1e-12, 0.5, 3, 4, 5, 6, 7};
  reg.observability.aligned_position_rmse_m = 0.00138;
  reg.observability.drift_model = DriftModelEstimate{0.108, 0.029, 0.0019, 0.079, 4, 2.5, 0.75};
  reg.warnings = {"one", "two"};
  reg.statistics.detections_total = 1000;
  reg.statistics.detections_associated = 990;
  reg.statistics.dropped_outside_trajectory = 7;
  reg.statistics.dropped_gap = 3;
  reg.statistics.seconds_per_stage = {{"associate", 0.01}, {"look_down", 0.25}};
  reg.statistics.seconds_per_step = {{"detect", 12.5}, {"odometry", 8.25}};
  reg.statistics.drive_seconds = 36.25;
  reg.config_yaml = "register:\n  pipeline: [associate, look_down]\n  look_down: {huber_m: 0.05}\n";
  for (int i = 0; i < 5; ++i) {
    reg.trajectory.push_back({1'700'000'000'000'000'000LL + i * 33'333'333LL, randomPose(rng)});
  }
  reg.blob_associations.push_back(
      {1'700'000'000'000'000'000LL, "cam01", 100.25, 200.5, 101, 202.125, 100.3, 200.4});
  return reg;
}

void expectPoseEq(const Rigid3d& a, const Rigid3d& b) {
  EXPECT_EQ(a.translation, b.translation);
  // Quaternions are written normalised; compare up to the sign and rounding of normalisation.
  EXPECT_NEAR(std::abs(a.rotation.normalized().dot(b.rotation.normalized())), 1.0, 1e-15);
}

class RegistrationIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_registration_io_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  // Saves the sample, replaces `from` by `to` in its registration.yaml, and
  // expects loading to fail naming the file and `field`.
  void expectLoadErrorNaming(const std::string& from, const std::string& to,
                             const std::string& field) {
    saveRegistration(sampleRegistration(), dir_);
    std::string yaml = readFile(dir_ / "registration.yaml");
    const size_t at = yaml.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    yaml.replace(at, from.size(), to);
    writeFileAtomically(dir_ / "registration.yaml", yaml);
    try {
      loadRegistration(dir_);
      FAIL() << "expected an error";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("registration.yaml:"), std::string::npos) << what;
      EXPECT_NE(what.find(field), std::string::npos) << what;
    }
  }
  fs::path dir_;
};

TEST_F(RegistrationIoTest, RoundTripsEveryField) {
  const Registration reg = sampleRegistration();
  saveRegistration(reg, dir_);
  const Registration back = loadRegistration(dir_);

  EXPECT_EQ(back.dataset, reg.dataset);
  EXPECT_EQ(back.created, reg.created);
  EXPECT_EQ(back.versions, reg.versions);
  EXPECT_EQ(back.pipeline, reg.pipeline);
  EXPECT_EQ(back.trajectory_mode, reg.trajectory_mode);
  EXPECT_EQ(back.trajectory_label, reg.trajectory_label);
  EXPECT_EQ(back.scale, reg.scale);
  EXPECT_EQ(back.scale_sigma, reg.scale_sigma);
  expectPoseEq(back.fisheye_from_marker, reg.fisheye_from_marker);
  EXPECT_EQ(back.fisheye_from_marker_covariance, reg.fisheye_from_marker_covariance);
  EXPECT_EQ(back.fisheye_from_marker_determined, reg.fisheye_from_marker_determined);
  EXPECT_EQ(back.fisheye_from_marker_prior, reg.fisheye_from_marker_prior);
  ASSERT_EQ(back.cameras.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const CameraRegistration& x = reg.cameras[i];
    const CameraRegistration& y = back.cameras[i];
    EXPECT_EQ(y.label, x.label);
    EXPECT_EQ(y.status, x.status);
    EXPECT_EQ(y.reason, x.reason);
    if (x.status != CameraStatus::kUnregistered) {
      expectPoseEq(y.world_from_camera, x.world_from_camera);
    }
    ASSERT_EQ(y.stage_poses.size(), x.stage_poses.size());
    for (const auto& [stage, pose] : x.stage_poses) expectPoseEq(y.stage_poses.at(stage), pose);
    ASSERT_EQ(y.covariance.has_value(), x.covariance.has_value());
    if (x.covariance) {
      EXPECT_EQ(*y.covariance, *x.covariance);
    }
    ASSERT_EQ(y.aligned_position_covariance.has_value(), x.aligned_position_covariance.has_value());
    if (x.aligned_position_covariance) {
      EXPECT_EQ(*y.aligned_position_covariance, *x.aligned_position_covariance);
    }
    EXPECT_EQ(y.detections.total, x.detections.total);
    EXPECT_EQ(y.detections.used, x.detections.used);
    EXPECT_EQ(y.detections.rejected, x.detections.rejected);
    EXPECT_EQ(y.detections.outside_trajectory, x.detections.outside_trajectory);
    ASSERT_EQ(y.residuals.has_value(), x.residuals.has_value());
    if (x.residuals) {
      EXPECT_EQ(y.residuals->position_rms_m, x.residuals->position_rms_m);
      EXPECT_EQ(y.residuals->rotation_rms_deg, x.residuals->rotation_rms_deg);
    }
    ASSERT_EQ(y.reprojection.has_value(), x.reprojection.has_value());
    if (x.reprojection) {
      EXPECT_EQ(y.reprojection->blobs, x.reprojection->blobs);
      EXPECT_EQ(y.reprojection->rms_px_before, x.reprojection->rms_px_before);
      EXPECT_EQ(y.reprojection->rms_px_after, x.reprojection->rms_px_after);
      EXPECT_EQ(y.reprojection->after_stage, x.reprojection->after_stage);
    }
    ASSERT_EQ(y.clock_offset.has_value(), x.clock_offset.has_value());
    if (x.clock_offset) {
      EXPECT_EQ(y.clock_offset->offset_ns, x.clock_offset->offset_ns);
      EXPECT_EQ(y.clock_offset->sigma_ms, x.clock_offset->sigma_ms);
      EXPECT_EQ(y.clock_offset->estimated, x.clock_offset->estimated);
    }
    EXPECT_EQ(y.warnings, x.warnings);
  }
  ASSERT_TRUE(back.reprojection);
  EXPECT_EQ(back.reprojection->blobs, 3000);
  EXPECT_EQ(back.reprojection->after_stage, "joint");
  EXPECT_EQ(back.observability.message, reg.observability.message);
  EXPECT_EQ(back.observability.eigenvalues, reg.observability.eigenvalues);
  ASSERT_TRUE(back.observability.aligned_position_rmse_m);
  EXPECT_DOUBLE_EQ(*back.observability.aligned_position_rmse_m, 0.00138);
  ASSERT_TRUE(back.observability.drift_model);
  EXPECT_DOUBLE_EQ(back.observability.drift_model->horizontal, 0.108);
  EXPECT_DOUBLE_EQ(back.observability.drift_model->vertical, 0.029);
  EXPECT_DOUBLE_EQ(back.observability.drift_model->tilt, 0.0019);
  EXPECT_DOUBLE_EQ(back.observability.drift_model->yaw, 0.079);
  EXPECT_EQ(back.observability.drift_model->updates, 4);
  EXPECT_EQ(back.observability.drift_model->between_samples_velocity_walk, 2.5);
  EXPECT_EQ(back.observability.drift_model->between_samples_rate_walk, 0.75);
  EXPECT_EQ(back.warnings, reg.warnings);
  EXPECT_EQ(back.statistics.detections_total, 1000);
  EXPECT_EQ(back.statistics.detections_associated, 990);
  EXPECT_EQ(back.statistics.dropped_outside_trajectory, 7);
  EXPECT_EQ(back.statistics.dropped_gap, 3);
  EXPECT_EQ(back.statistics.seconds_per_stage, reg.statistics.seconds_per_stage);
  EXPECT_EQ(back.statistics.seconds_per_step, reg.statistics.seconds_per_step);
  EXPECT_EQ(back.statistics.drive_seconds, reg.statistics.drive_seconds);
  EXPECT_NE(back.config_yaml.find("huber_m"), std::string::npos);
  ASSERT_EQ(back.trajectory.size(), reg.trajectory.size());
  for (size_t i = 0; i < reg.trajectory.size(); ++i) {
    EXPECT_EQ(back.trajectory[i].t, reg.trajectory[i].t);
    EXPECT_LT((back.trajectory[i].world_from_body.translation -
               reg.trajectory[i].world_from_body.translation)
                  .norm(),
              1e-12);
  }
  ASSERT_EQ(back.blob_associations.size(), 1u);
  EXPECT_EQ(back.blob_associations[0].t, reg.blob_associations[0].t);
  EXPECT_EQ(back.blob_associations[0].camera, "cam01");
  EXPECT_EQ(back.blob_associations[0].v_before, 202.125);
  EXPECT_EQ(back.registeredCount(), 2);
}

TEST_F(RegistrationIoTest, RoundTripsASiteFrameWithItsControlPoints) {
  Registration reg = sampleRegistration();
  reg.world_frame.name = "site";
  reg.world_frame.description = "the frame of the control points in site.csv";
  reg.world_frame.from_registration =
      Rigid3d(Eigen::Quaterniond(0.6, 0.8, 0.0, 0.0), Eigen::Vector3d(1.5, -2.0, 0.25));
  reg.world_frame.control_points = {
      {"cam00", Eigen::Vector3d(2.0, 3.0, 3.5), Eigen::Vector3d(0.001, -0.002, 0.0005), 0.75},
      {"cam01", Eigen::Vector3d(-1.25, 0.5, 3.75), Eigen::Vector3d(-0.0125, 0.0, 0.003), 3.5}};
  saveRegistration(reg, dir_);
  const Registration back = loadRegistration(dir_);
  EXPECT_EQ(back.world_frame.name, "site");
  EXPECT_EQ(back.world_frame.description, reg.world_frame.description);
  ASSERT_TRUE(back.world_frame.from_registration);
  expectPoseEq(*back.world_frame.from_registration, *reg.world_frame.from_registration);
  ASSERT_EQ(back.world_frame.control_points.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const ControlPointFit& a = reg.world_frame.control_points[i];
    const ControlPointFit& b = back.world_frame.control_points[i];
    EXPECT_EQ(b.name, a.name);
    EXPECT_EQ(b.p_in_site, a.p_in_site);
    EXPECT_EQ(b.residual_m, a.residual_m);
    EXPECT_EQ(b.sigmas, a.sigmas);
  }
}

TEST_F(RegistrationIoTest, CamerasCsvHasRegisteredAndSuspectOnly) {
  saveRegistration(sampleRegistration(), dir_);
  const std::string csv = readFile(dir_ / "cameras.csv");
  EXPECT_EQ(csv.rfind("label,tx,ty,tz,qx,qy,qz,qw\n", 0), 0u);
  EXPECT_NE(csv.find("\ncam01,"), std::string::npos);
  EXPECT_NE(csv.find("\ncam02,"), std::string::npos);
  EXPECT_EQ(csv.find("cam03"), std::string::npos);
}

TEST_F(RegistrationIoTest, ErrorsNameFileAndField) {
  expectLoadErrorNaming("status: suspect", "status: maybe", "cameras[1].status");
}

TEST_F(RegistrationIoTest, MissingDriftModelFactorIsNamed) {
  expectLoadErrorNaming("yaw: 0.079", "yawn: 0.079", "observability.drift_model");
}

TEST_F(RegistrationIoTest, RejectsAnotherFormat) {
  saveRegistration(sampleRegistration(), dir_);
  std::string yaml = readFile(dir_ / "registration.yaml");
  const size_t at = yaml.find("lookboth-registration 1");
  yaml.replace(at, 23, "lookboth-registration 9");
  writeFileAtomically(dir_ / "registration.yaml", yaml);
  EXPECT_THROW(loadRegistration(dir_), Error);
}

TEST_F(RegistrationIoTest, BadBlobRowNamesLine) {
  saveRegistration(sampleRegistration(), dir_);
  {
    std::ofstream out(dir_ / "blob_associations.csv", std::ios::app);
    out << "12,cam01,1,2,3,x,5,6\n";
  }
  try {
    loadRegistration(dir_);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("blob_associations.csv:3"), std::string::npos) << what;
    EXPECT_NE(what.find("v_before"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace lookboth
