#include "lookboth/report/pose_comparison.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "lookboth/core/error.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"

namespace lookboth::report {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = M_PI / 180.0;

Rigid3d randomPose(std::mt19937& rng, double spread) {
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Vector3d omega = drawVector<3>([&] { return u(rng); }) * M_PI;
  const Eigen::Vector3d t = drawVector<3>([&] { return u(rng); });
  return Rigid3d(so3Exp(Eigen::Vector3d(omega / std::max(1.0, omega.norm() / 3.0))),
                 Eigen::Vector3d(t.x() * spread, t.y() * spread, 3 + t.z() * 0.5));
}

CameraPoseSet randomCameras(int n, std::mt19937& rng) {
  CameraPoseSet set;
  set.source = "truth";
  for (int i = 0; i < n; ++i) {
    set.world_from_camera["cam" + std::to_string(10 + i)] = randomPose(rng, 10);
  }
  return set;
}

CameraPoseSet transformed(const CameraPoseSet& set, const Sim3d& b_from_a) {
  CameraPoseSet out;
  out.source = "estimate";
  for (const auto& [label, pose] : set.world_from_camera) {
    out.world_from_camera[label] = b_from_a.transformPose(pose);
  }
  return out;
}

TEST(Evaluate, NoiseFreeRecoveryUpToRigidTransform) {
  std::mt19937 rng(3);
  const CameraPoseSet truth = randomCameras(12, rng);
  const Rigid3d estimate_from_truth = randomPose(rng, 50);
  const CameraPoseSet estimate = transformed(truth, Sim3d(estimate_from_truth));
  const PoseComparison c = comparePoses(truth, estimate);
  ASSERT_EQ(c.cameras.size(), 12u);
  EXPECT_LT(c.rms.position_m_total, 1e-9);
  EXPECT_LT(c.rms.rotation_deg_total, 1e-7);
  EXPECT_LT(c.rms.roll_pitch_yaw_deg.norm(), 1e-7);
  // The alignment is the inverse of the transform applied.
  const Rigid3d truth_from_estimate = estimate_from_truth.inverse();
  EXPECT_LT((c.reference_from_estimate.translation - truth_from_estimate.translation).norm(), 1e-9);
  EXPECT_LT(rotationAngleBetween(c.reference_from_estimate.rotation, truth_from_estimate.rotation),
            1e-9);
  EXPECT_DOUBLE_EQ(c.reference_from_estimate.scale, 1.0);
}

TEST(Evaluate, SimilarityNeedsWithScale) {
  std::mt19937 rng(5);
  const CameraPoseSet truth = randomCameras(8, rng);
  const Rigid3d rigid = randomPose(rng, 5);
  const Sim3d estimate_from_truth(0.4, rigid.rotation, rigid.translation);
  const CameraPoseSet estimate = transformed(truth, estimate_from_truth);
  const PoseComparison with_scale = comparePoses(truth, estimate, CompareOptions{true});
  EXPECT_LT(with_scale.rms.position_m_total, 1e-9);
  EXPECT_LT(with_scale.rms.rotation_deg_total, 1e-7);
  EXPECT_NEAR(with_scale.reference_from_estimate.scale, 1 / 0.4, 1e-9);
  const PoseComparison rigid_only = comparePoses(truth, estimate, CompareOptions{false});
  EXPECT_GT(rigid_only.rms.position_m_total, 1.0);  // a scale error cannot be aligned away
}

// Known perturbations give the expected numbers: rotations do not affect the
// alignment (positions only), and a "saddle" of height offsets on a square is
// orthogonal to every rigid motion, so the alignment stays the identity.
TEST(Evaluate, KnownPerturbationsGiveExpectedNumbers) {
  CameraPoseSet truth;
  truth.source = "truth";
  const Eigen::Quaterniond down(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));
  const double corners[4][2] = {{1, 1}, {-1, -1}, {1, -1}, {-1, 1}};
  for (int i = 0; i < 4; ++i) {
    truth.world_from_camera["c" + std::to_string(i)] =
        Rigid3d(down, Eigen::Vector3d(corners[i][0] * 3, corners[i][1] * 3, 3.5));
  }
  CameraPoseSet estimate = truth;
  estimate.source = "estimate";
  const double dz = 0.02;
  for (int i = 0; i < 4; ++i) {
    Rigid3d& pose = estimate.world_from_camera["c" + std::to_string(i)];
    pose.translation.z() += (i < 2 ? dz : -dz);
  }
  // c0: 2 deg about world z (yaw), c1: 1.5 deg about world x (roll), c2: 1 deg about y (pitch).
  estimate.world_from_camera["c0"].rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(2 * kDeg, Eigen::Vector3d::UnitZ())) * down;
  estimate.world_from_camera["c1"].rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(1.5 * kDeg, Eigen::Vector3d::UnitX())) * down;
  estimate.world_from_camera["c2"].rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(-1 * kDeg, Eigen::Vector3d::UnitY())) * down;

  const PoseComparison c = comparePoses(truth, estimate);
  EXPECT_NEAR(c.rms.position_m.x(), 0, 1e-9);
  EXPECT_NEAR(c.rms.position_m.y(), 0, 1e-9);
  EXPECT_NEAR(c.rms.position_m.z(), dz, 1e-9);
  EXPECT_NEAR(c.rms.position_m_total, dz, 1e-9);
  EXPECT_NEAR(c.rms.position_m_max, dz, 1e-9);
  EXPECT_NEAR(c.rms.roll_pitch_yaw_deg.z(), std::sqrt(4.0 / 4), 1e-6);   // yaw: 2 deg on 1 of 4
  EXPECT_NEAR(c.rms.roll_pitch_yaw_deg.x(), std::sqrt(2.25 / 4), 1e-6);  // roll: 1.5 deg
  EXPECT_NEAR(c.rms.roll_pitch_yaw_deg.y(), std::sqrt(1.0 / 4), 1e-6);   // pitch: 1 deg
  EXPECT_NEAR(c.rms.rotation_deg_total, std::sqrt((4 + 2.25 + 1) / 4), 1e-6);
  EXPECT_NEAR(c.rms.rotation_deg_max, 2, 1e-6);
  ASSERT_EQ(c.cameras[0].label, "c0");
  EXPECT_NEAR(c.cameras[0].roll_pitch_yaw_deg.z(), 2, 1e-6);
  EXPECT_NEAR(c.cameras[2].roll_pitch_yaw_deg.y(), -1, 1e-6);
  EXPECT_NEAR(c.cameras[0].position_m.z(), dz, 1e-9);
  EXPECT_NEAR(c.cameras[2].position_m.z(), -dz, 1e-9);
}

// The predicted covariance is in the estimate's axes: the NEES turns it into
// the reference's. The estimate's world is the reference's turned by -90 deg
// about x, so a height error in the reference is along the estimate's y,
// the one axis with a small sigma (1 cm): the 2 cm errors give 4 per camera.
TEST(Evaluate, PositionNeesUsesThePredictedCovarianceInTheReferenceAxes) {
  CameraPoseSet truth;
  truth.source = "truth";
  const Eigen::Quaterniond down(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));
  const double corners[4][2] = {{1, 1}, {-1, -1}, {1, -1}, {-1, 1}};
  const Rigid3d estimate_from_reference(
      Eigen::Quaterniond(Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX())),
      Eigen::Vector3d(5, -2, 1));
  CameraPoseSet estimate;
  estimate.source = "estimate";
  for (int i = 0; i < 4; ++i) {
    const std::string label = "c" + std::to_string(i);
    const Rigid3d pose(down, Eigen::Vector3d(corners[i][0] * 3, corners[i][1] * 3, 3.5));
    truth.world_from_camera[label] = pose;
    // +-2 cm in height as a saddle (z ~ x y), which no rigid motion removes.
    Rigid3d moved = pose;
    moved.translation.z() += (i < 2 ? 0.02 : -0.02);
    estimate.world_from_camera[label] = estimate_from_reference * moved;
    estimate.aligned_position_covariance[label] = Eigen::Vector3d(1, 1e-4, 1).asDiagonal();
  }
  const PoseComparison c = comparePoses(truth, estimate);
  ASSERT_TRUE(c.position_nees_per_dof);
  EXPECT_NEAR(*c.position_nees_per_dof, 4.0 / 3, 1e-6);
  EXPECT_NE(evaluationToJson({"reg", c, std::nullopt, std::nullopt, std::nullopt})
                .find("\"position_nees_per_dof\""),
            std::string::npos);

  EXPECT_FALSE(comparePoses(truth, estimate, {true}).position_nees_per_dof) << "Sim(3)";
  CameraPoseSet partly = estimate;
  partly.aligned_position_covariance.erase("c3");
  EXPECT_FALSE(comparePoses(truth, partly).position_nees_per_dof) << "a camera without";
  EXPECT_FALSE(comparePoses(estimate, estimate).position_nees_per_dof) << "against a registration";
}

TEST(Evaluate, UnregisteredCamerasAreListedNotCounted) {
  std::mt19937 rng(9);
  const CameraPoseSet truth = randomCameras(6, rng);
  CameraPoseSet estimate = truth;
  estimate.source = "estimate";
  // A wildly wrong pose that must not count, because the camera is unregistered.
  estimate.world_from_camera.erase("cam12");
  estimate.without_pose = {"cam12"};
  estimate.world_from_camera["extra"] = randomPose(rng, 3);
  const PoseComparison c = comparePoses(truth, estimate);
  EXPECT_EQ(c.cameras.size(), 5u);
  EXPECT_LT(c.rms.position_m_total, 1e-9);
  EXPECT_EQ(c.missing_in_estimate, std::vector<std::string>{"cam12"});
  EXPECT_EQ(c.missing_in_reference, std::vector<std::string>{"extra"});
}

TEST(Evaluate, TooFewCommonCamerasIsAnError) {
  std::mt19937 rng(2);
  const CameraPoseSet truth = randomCameras(5, rng);
  CameraPoseSet estimate;
  estimate.source = "two cameras";
  estimate.world_from_camera["cam10"] = truth.world_from_camera.at("cam10");
  estimate.world_from_camera["cam11"] = truth.world_from_camera.at("cam11");
  try {
    comparePoses(truth, estimate);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("two cameras"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("2 common camera"), std::string::npos) << e.what();
  }
}

TEST(Evaluate, RollPitchYawRoundTrip) {
  for (const Eigen::Vector3d& rpy :
       {Eigen::Vector3d(0.1, -0.2, 0.3), Eigen::Vector3d(3.0, 0.5, -2.5),
        Eigen::Vector3d(-1.0, 1.2, 0.0)}) {
    const Eigen::Matrix3d r = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    EXPECT_LT((rollPitchYaw(r) - rpy).norm(), 1e-12);
  }
}

class CamerasCsv : public ::testing::Test {
 protected:
  fs::path write(const std::string& text) {
    const fs::path path =
        fs::temp_directory_path() / ("lookboth_report_cameras_" + std::to_string(::getpid()) + "_" +
                                     std::to_string(counter_++) + ".csv");
    std::ofstream(path) << text;
    paths_.push_back(path);
    return path;
  }
  ~CamerasCsv() override {
    for (const auto& p : paths_) fs::remove(p);
  }
  std::string errorOf(const std::string& text) {
    const fs::path path = write(text);
    try {
      readCamerasCsv(path);
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  }
  std::vector<fs::path> paths_;
  int counter_ = 0;
};

TEST_F(CamerasCsv, ReadsAnyColumnOrder) {
  const fs::path path =
      write("# comment\nqw,qx,qy,qz,label,tx,ty,tz\n1,0,0,0,a,1,2,3\n\n0,1,0,0,b,4,5,6\n");
  const CameraPoseSet set = readCamerasCsv(path);
  ASSERT_EQ(set.world_from_camera.size(), 2u);
  EXPECT_EQ(set.world_from_camera.at("b").translation, Eigen::Vector3d(4, 5, 6));
  EXPECT_NEAR(set.world_from_camera.at("b").rotation.x(), 1, 1e-15);
}

TEST_F(CamerasCsv, BadInputNamesFileLineAndColumn) {
  const std::string header = "label,tx,ty,tz,qx,qy,qz,qw\n";
  std::string e = errorOf(header + "a,1,2,3,0,0,0,1\nb,1,x,3,0,0,0,1\n");
  EXPECT_NE(e.find(".csv:3: 'ty': not a number: 'x' [b]"), std::string::npos) << e;
  e = errorOf(header + "a,1,2,3,0,0,0,1.1\n");
  EXPECT_NE(e.find(".csv:2: 'qx,qy,qz,qw': quaternion"), std::string::npos) << e;
  e = errorOf("label,tx,ty,tz,qx,qy,qz\n");
  EXPECT_NE(e.find(".csv:1: 'qw': required column is missing"), std::string::npos) << e;
  e = errorOf(header + "a,1,2,3,0,0,0,1\na,1,2,3,0,0,0,1\n");
  EXPECT_NE(e.find(".csv:3: 'label': camera listed twice [a]"), std::string::npos) << e;
  e = errorOf(header + "a,1,2,3\n");
  EXPECT_NE(e.find(".csv:2: 'qx': the row has 4 fields"), std::string::npos) << e;
  e = errorOf(header + "a,nan,2,3,0,0,0,1\n");
  EXPECT_NE(e.find(".csv:2: 'tx'"), std::string::npos) << e;
  try {
    loadGroundTruthPoses("/nonexistent/folder");
    FAIL();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("/nonexistent/folder: no such file"),
              std::string::npos);
  }
}

TEST(Evaluate, ReprojectionTableAndJson) {
  std::vector<ReprojectionRow> rows;
  rows.push_back({1, "a", 100, 100, Eigen::Vector2d(103, 104), Eigen::Vector2d(100, 101)});  // 5, 1
  rows.push_back({2, "a", 50, 50, Eigen::Vector2d(50, 45), Eigen::Vector2d(50, 50)});        // 5, 0
  rows.push_back({2, "b", 10, 10, std::nullopt, Eigen::Vector2d(12, 10)});                   // -, 2
  const ReprojectionTable table = reprojectionTable(rows);
  EXPECT_EQ(table.total.blobs, 3);
  EXPECT_EQ(table.total.blobs_before, 2);
  EXPECT_NEAR(table.total.rms_px_before, 5, 1e-12);
  EXPECT_NEAR(table.total.rms_px_after, std::sqrt((1.0 + 0 + 4) / 3), 1e-12);
  EXPECT_NEAR(table.by_camera.at("a").rms_px_after, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(table.by_camera.at("b").max_px_after, 2, 1e-12);

  std::mt19937 rng(1);
  const CameraPoseSet truth = randomCameras(4, rng);
  Evaluation evaluation;
  evaluation.registration = "out";
  evaluation.ground_truth = comparePoses(truth, transformed(truth, Sim3d()));
  evaluation.reprojection = table;
  const nlohmann::json j = nlohmann::json::parse(evaluationToJson(evaluation));
  EXPECT_EQ(j["format"], "lookboth-evaluation 1");
  EXPECT_EQ(j["ground_truth"]["cameras"].size(), 4u);
  EXPECT_EQ(j["ground_truth"]["alignment"]["type"], "SE3");
  EXPECT_LT(j["ground_truth"]["rms"]["position_m"].get<double>(), 1e-9);
  EXPECT_NEAR(j["reprojection"]["rms_px_before"].get<double>(), 5, 1e-12);
  EXPECT_EQ(j["reprojection"]["cameras"]["b"]["blobs_before"], 0);
  EXPECT_FALSE(j.contains("against"));
}

}  // namespace
}  // namespace lookboth::report
