// Re-checking a facility: ground truth -> two registrations with their own
// noise (the second in another frame, some cameras moved) -> check -> the
// moved cameras flagged, the others no more often than the check's false-alarm rate.
#include "lookboth/registration/facility_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <set>

#include "lookboth/core/error.h"
#include "lookboth/core/test_seed.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"

namespace lookboth {
namespace {

constexpr double kSigmaPosition = 0.002;             // per axis [m]
constexpr double kSigmaRotation = 0.1 * M_PI / 180;  // per axis [rad]

// A camera that has not moved is flagged when its position or its rotation
// difference passes chi-square(3) at 99.9 % (FacilityCheckOptions::max_chi2;
// the tolerances, 1 cm and 0.5 deg, are below those 4 sigmas here): on noise
// alone 2 in 1000 cameras, so false flags are counted against that rate, not
// required to be none. The bounds are Poisson quantiles: exceeded with a
// probability below 1e-3.
constexpr double kFalseFlagRate = 2 * 0.000998;

// The most false flags among `cameras` unmoved ones: P(Poisson(rate n) > it) < 1e-3.
int maxFalseFlags(int cameras) {
  const double mean = kFalseFlagRate * cameras;
  double term = std::exp(-mean), below = term;
  int k = 0;
  while (1 - below >= 1e-3) {
    term *= mean / ++k;
    below += term;
  }
  return k;
}

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
  const std::set<std::string> moved_labels = {"cam05", "cam17", "cam30"};
  int false_flags = 0, unmoved = 0;
  const unsigned first = testSeedBlock(1, 5);
  for (unsigned seed = first; seed < first + 5; ++seed) {
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
    for (const std::string& label : moved_labels) {
      EXPECT_EQ(flagged.count(label), 1u) << label << ", seed " << seed;
    }
    const int wrongly = static_cast<int>(flagged.size()) - 3;
    false_flags += wrongly;
    unmoved += 39;
    EXPECT_EQ(check.not_seen, 1);
    EXPECT_EQ(check.unchanged, 39 - wrongly);
    // The alignment recovers the frame to about a millimetre.
    const Rigid3d expected = other_frame.inverse();
    const double frame_error = (check.record_from_new.translation - expected.translation).norm();
    std::cout << "seed " << seed << ": frame translation error " << frame_error * 1e3 << " mm\n";
    EXPECT_LT(frame_error, 0.003);
    EXPECT_NEAR(check.cameras[5].moved_m.x(), -0.03, 0.01);
    EXPECT_NEAR(check.cameras[17].rotated_deg, 1.0, 0.4);
  }
  std::cout << "unmoved cameras flagged: " << false_flags << " of " << unmoved << "\n";
  EXPECT_LE(false_flags, maxFalseFlags(unmoved));
}

TEST(FacilityCheck, NoiseAloneIsUnchangedAndTheStatisticFitsItsDof) {
  const std::vector<Rigid3d> truth = facility(43);
  double chi2 = 0;
  int n = 0, flagged = 0;
  const unsigned first = testSeedBlock(10, 20);
  for (unsigned seed = first; seed < first + 20; ++seed) {
    std::mt19937 rng(seed);
    const Registration record = noisyCopy(truth, Rigid3d(), rng);
    const Registration fresh = noisyCopy(truth, Rigid3d(), rng);
    const FacilityCheck check = checkFacility(fresh, record);
    flagged += check.moved;
    for (const CameraCheck& c : check.cameras) {
      chi2 += c.position_chi2;
      ++n;
    }
  }
  // 3 dof per camera, less the alignment's 6 over 43 cameras.
  const double per_dof = chi2 / n / 3;
  std::cout << "position chi2 per dof over " << n << " cameras: " << per_dof << "; flagged "
            << flagged << "\n";
  EXPECT_LE(flagged, maxFalseFlags(n));
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
