// `register --update` on synthetic problems (COLMAP style): a record in a
// frame of its own, a later drive whose cameras are where the record says
// but one, which moved. Noise-free, the update puts every camera and the
// trajectory where the truth is in the record's frame (to 1e-6); the moved
// camera is found, registered again, and the others are held at the record.
#include <gtest/gtest.h>

#include "lookboth/calib/builtin_stages.h"
#include "lookboth/calib/record_update.h"
#include "lookboth/geometry/lie.h"
#include "synthetic.h"

namespace lookboth {
namespace {

using testing::makeSyntheticScene;
using testing::SyntheticScene;

constexpr double kDeg = M_PI / 180.0;

// The record's frame in the drive's (the synthetic scene's world).
const Rigid3d kRecordFromWorld(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
                                                  Eigen::AngleAxisd(0.02,
                                                                    Eigen::Vector3d::UnitX())),
                               Eigen::Vector3d(12.0, -3.5, 0.4));

RegistrationProblem registerDrive(const SyntheticScene& scene, const JointOptions& joint = {}) {
  RegistrationProblem problem = testing::stagesBeforeJoint(scene);
  runJoint(problem, joint, ProgressReporter());
  return problem;
}

// The facility as recorded: the truth in the record's frame, `moved` where it
// was before it moved (3 cm along x), and a camera this drive does not pass.
Registration makeRecord(const SyntheticScene& scene, const std::string& moved) {
  Registration record;
  record.dataset = "first-drive";
  record.world_frame.name = "site";
  for (const auto& [label, pose] : scene.world_from_camera) {
    CameraRegistration c;
    c.label = label;
    c.status = CameraStatus::kRegistered;
    c.world_from_camera = kRecordFromWorld * pose;
    if (label == moved) c.world_from_camera.translation.x() -= 0.03;
    Matrix6d covariance = Matrix6d::Zero();
    covariance.diagonal() << 1e-6, 1e-6, 1e-6, 3e-6, 3e-6, 3e-6;
    c.covariance = covariance;
    record.cameras.push_back(c);
  }
  CameraRegistration away = record.cameras.front();
  away.label = "cam99";
  away.world_from_camera.translation.z() += 5;
  record.cameras.push_back(away);
  return record;
}

TEST(RecordUpdate, NoiseFreeUpdateIsExactInTheRecordsFrame) {
  const SyntheticScene scene = makeSyntheticScene({});
  const std::string moved = scene.world_from_camera.begin()->first;
  const Registration record = makeRecord(scene, moved);
  RegistrationProblem problem = registerDrive(scene);
  const FacilityCheck check = checkFacility(problem.result, record);
  EXPECT_EQ(check.moved, 1);
  EXPECT_EQ(check.not_seen, 1);
  EXPECT_EQ(check.unchanged, static_cast<int>(scene.world_from_camera.size()) - 1);

  EXPECT_EQ(holdAtRecord(problem, record, check), check.unchanged);
  runJoint(problem, {}, ProgressReporter());
  const Registration updated = mergeIntoRecord(record, problem.result, check);

  ASSERT_EQ(updated.cameras.size(), record.cameras.size());
  EXPECT_EQ(updated.world_frame.name, "site");
  for (const CameraRegistration& c : updated.cameras) {
    ASSERT_NE(c.status, CameraStatus::kUnregistered) << c.label;
    ASSERT_FALSE(c.notes.empty()) << c.label;
    EXPECT_EQ(c.notes.back().rfind("update: ", 0), 0u) << c.notes.back();
    if (c.label == "cam99") {  // not seen: as recorded
      EXPECT_EQ(c.world_from_camera.translation,
                record.findCamera("cam99")->world_from_camera.translation);
      continue;
    }
    const Rigid3d truth = kRecordFromWorld * scene.world_from_camera.at(c.label);
    EXPECT_LT((c.world_from_camera.translation - truth.translation).norm(), 1e-6) << c.label;
    EXPECT_LT(so3Log(Eigen::Quaterniond(truth.rotation.conjugate() * c.world_from_camera.rotation))
                  .norm(),
              1e-6 * kDeg)
        << c.label;
    ASSERT_TRUE(c.covariance) << c.label;
  }
  EXPECT_NE(updated.findCamera(moved)->notes.back().find("moved 30.0 mm"), std::string::npos)
      << updated.findCamera(moved)->notes.back();
  ASSERT_TRUE(problem.metric_trajectory);
  for (const StampedPose& p : *problem.metric_trajectory) {
    const auto truth = Trajectory(scene.truth).interpolate(p.t, 0);
    ASSERT_TRUE(truth.ok());
    ASSERT_LT(
        ((kRecordFromWorld * truth.world_from_body).translation - p.world_from_body.translation)
            .norm(),
        1e-6);
  }
}

// The held cameras' covariance carries the record's: information adds, so a
// held camera ends more certain than both the record and this drive alone
// (the errors a pass shares left out: they are not the prior's business).
TEST(RecordUpdate, HeldCamerasTakeTheRecordsWeight) {
  const SyntheticScene scene = makeSyntheticScene({});
  const Registration record = makeRecord(scene, "");
  JointOptions joint;
  joint.pass_error_share = 0;
  joint.blob_pass_error_share = 0;
  RegistrationProblem problem = registerDrive(scene, joint);
  std::map<std::string, double> alone;
  for (const CameraRegistration& c : problem.result.cameras) {
    ASSERT_TRUE(c.covariance);
    alone[c.label] = c.covariance->topLeftCorner<3, 3>().trace();
  }
  const FacilityCheck check = checkFacility(problem.result, record);
  ASSERT_EQ(check.moved, 0);
  holdAtRecord(problem, record, check);
  runJoint(problem, joint, ProgressReporter());
  for (const CameraRegistration& c : problem.result.cameras) {
    ASSERT_TRUE(c.covariance) << c.label;
    const double held = c.covariance->topLeftCorner<3, 3>().trace();
    EXPECT_LT(held, 3e-6 + 1e-12) << c.label;  // at most the record's 3 x 1e-6 m^2
    EXPECT_GT(alone[c.label], held) << c.label;
  }
}

TEST(RecordUpdate, NothingToHoldIsAnError) {
  const SyntheticScene scene = makeSyntheticScene({});
  Registration record = makeRecord(scene, "");
  for (CameraRegistration& c : record.cameras) c.covariance.reset();
  RegistrationProblem problem = registerDrive(scene);
  const FacilityCheck check = checkFacility(problem.result, record);
  EXPECT_THROW(holdAtRecord(problem, record, check), Error);
}

}  // namespace
}  // namespace lookboth
