// Re-checking a facility: ground truth -> two registrations with their own
// noise (the second in another frame, some cameras moved) -> check -> the
// moved cameras flagged and no other.
#include "lookboth/registration/facility_check.h"

#include <gtest/gtest.h>

#include <random>
#include <set>

#include "lookboth/core/error.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"

namespace lookboth {
namespace {

constexpr double kSigmaPosition = 0.002;             // per axis [m]
constexpr double kSigmaRotation = 0.1 * M_PI / 180;  // per axis [rad]

Registration noisyCopy(const std::vector<Rigid3d>& truth, const Rigid3d& frame, std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Registration reg;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    CameraRegistration c;
    c.label = "cam" + std::to_string(100 + i).substr(1);
    c.status = CameraStatus::kRegistered;
    const Eigen::Vector3d dt = drawVector<3>([&] { return n(rng); });
    const Eigen::Vector3d dtheta = drawVector<3>([&] { return n(rng); });
    const Rigid3d noisy(truth[i].rotation * so3Exp(Eigen::Vector3d(kSigmaRotation * dtheta)),
                        truth[i].translation + kSigmaPosition * dt);
    c.world_from_camera = frame * noisy;
    Matrix6d covariance = Matrix6d::Zero();
    covariance.diagonal() << Eigen::Vector3d::Constant(kSigmaPosition * kSigmaPosition),
        Eigen::Vector3d::Constant(kSigmaRotation * kSigmaRotation);
    // The position block in the registration's frame.
    const Eigen::Matrix3d r = frame.rotation.toRotationMatrix();
    covariance.topLeftCorner<3, 3>() = r * covariance.topLeftCorner<3, 3>() * r.transpose();
    c.covariance = covariance;
    reg.cameras.push_back(c);
  }
  return reg;
}

std::vector<Rigid3d> facility(int count) {
  std::vector<Rigid3d> cameras;
  const Eigen::Quaterniond down(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));
  for (int i = 0; i < count; ++i) {
    cameras.emplace_back(
        down * Eigen::Quaterniond(Eigen::AngleAxisd(0.3 * i, Eigen::Vector3d::UnitZ())),
        Eigen::Vector3d(5.0 * (i % 9), 6.0 * (i / 9), 3.0 + 0.1 * (i % 4)));
  }
  return cameras;
}

TEST(FacilityCheck, FlagsExactlyTheCamerasThatMoved) {
  const std::vector<Rigid3d> truth = facility(43);
  const Rigid3d other_frame(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d(0.1, 0.2, 1).normalized())),
      Eigen::Vector3d(-7, 3, 0.5));
  for (unsigned seed = 1; seed <= 5; ++seed) {
    std::mt19937 rng(seed);
    std::vector<Rigid3d> moved = truth;
    moved[5].translation.x() += 0.03;
    moved[17].rotation = moved[17].rotation * so3Exp(Eigen::Vector3d(M_PI / 180, 0, 0));
    moved[30].translation.z() -= 0.03;
    const Registration record = noisyCopy(truth, Rigid3d(), rng);
    Registration fresh = noisyCopy(moved, other_frame, rng);
    fresh.cameras[40].status = CameraStatus::kUnregistered;  // not seen by the new drive
    const FacilityCheck check = checkFacility(fresh, record);
    std::set<std::string> flagged;
    for (const CameraCheck& c : check.cameras) {
      if (c.verdict == CameraVerdict::kMoved) flagged.insert(c.label);
    }
    EXPECT_EQ(flagged, (std::set<std::string>{"cam05", "cam17", "cam30"})) << "seed " << seed;
    EXPECT_EQ(check.not_seen, 1);
    EXPECT_EQ(check.unchanged, 39);
    // The alignment recovers the frame to about a millimetre.
    const Rigid3d expected = other_frame.inverse();
    EXPECT_LT((check.record_from_new.translation - expected.translation).norm(), 0.003);
    EXPECT_NEAR(check.cameras[5].moved_m.x(), -0.03, 0.01);
    EXPECT_NEAR(check.cameras[17].rotated_deg, 1.0, 0.4);
  }
}

TEST(FacilityCheck, NoiseAloneIsUnchangedAndTheStatisticFitsItsDof) {
  const std::vector<Rigid3d> truth = facility(43);
  double chi2 = 0;
  int n = 0;
  for (unsigned seed = 10; seed < 30; ++seed) {
    std::mt19937 rng(seed);
    const Registration record = noisyCopy(truth, Rigid3d(), rng);
    const Registration fresh = noisyCopy(truth, Rigid3d(), rng);
    const FacilityCheck check = checkFacility(fresh, record);
    EXPECT_EQ(check.moved, 0) << "seed " << seed;
    for (const CameraCheck& c : check.cameras) {
      chi2 += c.position_chi2;
      ++n;
    }
  }
  // 3 dof per camera, less the alignment's 6 over 43 cameras.
  const double per_dof = chi2 / n / 3;
  EXPECT_GT(per_dof, 0.8);
  EXPECT_LT(per_dof, 1.1);
}

TEST(FacilityCheck, NewCamerasAndTooFewInCommon) {
  std::mt19937 rng(3);
  const std::vector<Rigid3d> truth = facility(6);
  Registration record = noisyCopy(truth, Rigid3d(), rng);
  const Registration fresh = noisyCopy(truth, Rigid3d(), rng);
  record.cameras[2].status = CameraStatus::kUnregistered;
  const FacilityCheck check = checkFacility(fresh, record);
  EXPECT_EQ(check.added, 1);
  EXPECT_EQ(check.cameras.back().label, "cam02");
  for (int i = 0; i < 4; ++i) record.cameras[i].status = CameraStatus::kUnregistered;
  EXPECT_THROW(checkFacility(fresh, record), Error);
}

}  // namespace
}  // namespace lookboth
