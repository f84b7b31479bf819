#include "lookboth/detect/marker_detector.h"

#include <gtest/gtest.h>

#include <array>

#include <sstream>

#include <Eigen/Eigenvalues>
#include <numeric>

#include <unistd.h>
#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <opencv2/aruco.hpp>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/core/test_seed.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/marker_dictionary.h"
#include "lookboth/detect/detection_evaluation.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"
#include "lookboth/sim/render.h"
#include "lookboth/sim/world.h"

namespace lookboth {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
const MarkerSpec kMarker{"DICT_4X4_50", 7, 0.2};

Camera envCamera() {
  return loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/ceiling_camera_ros.yaml");
}
Camera fisheyeEnvCamera() {  // a fisheye looking down: the model must not be assumed pinhole
  return loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_kannala_brandt.yaml");
}

Eigen::Quaterniond rotZ(double a) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()));
}

/// A camera looking down from `position`, tilted by `tilt` about a horizontal axis.
Rigid3d lookingDown(const Eigen::Vector3d& position, double yaw, double tilt, double direction) {
  const Eigen::Quaterniond down(Eigen::Matrix3d(Eigen::Vector3d(1, -1, -1).asDiagonal()));
  const Eigen::Vector3d axis(std::cos(direction), std::sin(direction), 0.0);
  return Rigid3d(rotZ(yaw) * Eigen::Quaterniond(Eigen::AngleAxisd(tilt, axis)) * down, position);
}

std::array<Eigen::Vector2d, 4> projectCorners(const Camera& camera,
                                              const Rigid3d& camera_from_marker, double side) {
  const double h = side / 2;
  const Eigen::Vector3d object[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  std::array<Eigen::Vector2d, 4> px;
  for (int k = 0; k < 4; ++k)
    px[static_cast<size_t>(k)] = *camera.project(camera_from_marker * object[k]);
  return px;
}

/// Error of an estimate over [dt; dtheta] (R_true = R * Exp(dtheta)).
Eigen::Matrix<double, 6, 1> poseError(const Rigid3d& estimate, const Rigid3d& truth) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = truth.translation - estimate.translation;
  e.tail<3>() = so3Log(Eigen::Quaterniond(estimate.rotation.conjugate() * truth.rotation));
  return e;
}

/// The marker 2.7-4.2 m below the camera, tilted a little, at a random place in view.
Rigid3d randomMarkerPose(const Camera& camera, std::mt19937& rng, double max_off_axis_deg) {
  std::uniform_real_distribution<double> u(-1, 1);
  for (;;) {
    const double distance = 3.45 + 0.75 * u(rng);
    const double angle = max_off_axis_deg * kDeg * std::abs(u(rng));
    const double azimuth = 3.14159 * u(rng);
    const Eigen::Vector3d direction(std::sin(angle) * std::cos(azimuth),
                                    std::sin(angle) * std::sin(azimuth), std::cos(angle));
    // Facing the camera's axis (marker z towards -z of the camera), small tilt, any yaw.
    const Eigen::Quaterniond facing(Eigen::Matrix3d(Eigen::Vector3d(1, -1, -1).asDiagonal()));
    const Eigen::Vector2d axis = drawVector<2>([&] { return u(rng); });
    const double tilt_angle = 3 * kDeg * u(rng);
    const Eigen::Quaterniond tilt(
        Eigen::AngleAxisd(tilt_angle, Eigen::Vector3d(axis.x(), axis.y(), 0).normalized()));
    const Rigid3d pose(facing * tilt * rotZ(3.14159 * u(rng)), distance * direction);
    bool inside = true;
    for (const Eigen::Vector2d& p : projectCorners(camera, pose, 0.2))
      inside = inside && camera.isInImage(p, 20);
    if (inside) return pose;
  }
}

TEST(MarkerPose, NoiseFreeCornersGiveTheExactPoseThroughAnyModel) {
  for (const Camera& camera : {envCamera(), fisheyeEnvCamera()}) {
    SCOPED_TRACE(camera.description());
    MarkerDetector detector(kMarker, camera);
    std::mt19937 rng(5);
    for (int trial = 0; trial < 20; ++trial) {
      const Rigid3d truth = randomMarkerPose(camera, rng, 35);
      const auto hypotheses = detector.solvePose(projectCorners(camera, truth, 0.2));
      ASSERT_FALSE(hypotheses.empty());
      const Eigen::Matrix<double, 6, 1> e = poseError(hypotheses.front().camera_from_marker, truth);
      EXPECT_LT(e.head<3>().norm(), 1e-7) << trial;
      EXPECT_LT(e.tail<3>().norm(), 1e-7) << trial;
      EXPECT_LT(hypotheses.front().reprojection_rms_px, 1e-6);
      // The information is symmetric positive definite.
      const Eigen::Matrix<double, 6, 6>& info = hypotheses.front().information;
      EXPECT_LT((info - info.transpose()).norm(), 1e-6 * info.norm());
      using Solver = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>;
      EXPECT_GT(Solver(info).eigenvalues().minCoeff(), 0.0);
    }
  }
}

TEST(MarkerPose, CovarianceMatchesTheErrorsOfNoisyCorners) {
  // Corners with Gaussian noise of the sigma the detector assumes: the
  // normalised error squared e^T I e is chi-square with 6 degrees of freedom
  // (mean 6, variance 12) to first order; over 400 trials its mean has a
  // standard deviation of sqrt(12 / 400) = 0.17. Beyond first order the pose
  // is non-linear in the corners (the tilt most: sim/marker_corners), which
  // lifts the mean to about 6.5 at this noise, with a spread of about 0.25
  // over noise realisations (6.20-7.10 over seed offsets 0-10): [5, 7.5] is
  // at least 4 of those sigmas from 6.5 on either side.
  // The hypothesis closest to the truth is scored (the ambiguity is a
  // separate question: see AmbiguityIsResolvedByTheTrack).
  const Camera camera = envCamera();
  MarkerDetectorOptions options;
  options.corner_sigma_px = 0.1;
  MarkerDetector detector(kMarker, camera, options);
  std::mt19937 rng(testSeed(11));
  std::normal_distribution<double> noise(0.0, options.corner_sigma_px);
  double sum = 0;
  int n = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const Rigid3d truth = randomMarkerPose(camera, rng, 35);
    auto corners = projectCorners(camera, truth, 0.2);
    for (Eigen::Vector2d& c : corners) c += drawVector<2>([&] { return noise(rng); });
    const auto hypotheses = detector.solvePose(corners);
    ASSERT_FALSE(hypotheses.empty());
    double best = 1e300;
    for (const MarkerPoseHypothesis& h : hypotheses) {
      const Eigen::Matrix<double, 6, 1> e = poseError(h.camera_from_marker, truth);
      best = std::min(best, e.dot(h.information * e));
    }
    sum += best;
    ++n;
  }
  const double mean_nees = sum / n;
  std::printf("synthetic corners, sigma %.2f px: mean NEES %.2f over %d trials (6 expected)\n",
              options.corner_sigma_px, mean_nees, n);
  EXPECT_GT(mean_nees, 5.0);
  EXPECT_LT(mean_nees, 7.5);
}

TEST(MarkerPose, AmbiguityIsResolvedByTheTrack) {
  // A small, far marker seen almost frontally with noisy corners: IPPE's two
  // hypotheses (tilted one way or the other) fit about equally well, and the
  // best-fitting one is often the wrong one. The track (the marker's normal
  // is the same in every frame) chooses right.
  const Camera camera = envCamera();
  MarkerDetector detector(kMarker, camera);
  std::mt19937 rng(testSeed(3));
  std::normal_distribution<double> noise(0.0, 0.3);
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Quaterniond facing(Eigen::Matrix3d(Eigen::Vector3d(1, -1, -1).asDiagonal()));
  const Eigen::Quaterniond tilt(
      Eigen::AngleAxisd(4 * kDeg, Eigen::Vector3d(1, 0.5, 0).normalized()));
  std::vector<MarkerDetection> detections;
  std::vector<Rigid3d> truths;
  for (int frame = 0; frame < 40; ++frame) {
    const Rigid3d truth(facing * tilt * rotZ(0.05 * frame),
                        Eigen::Vector3d(0.9 + 0.02 * frame, 0.3 * u(rng), 5.0));
    auto corners = projectCorners(camera, truth, 0.2);
    for (Eigen::Vector2d& c : corners) c += drawVector<2>([&] { return noise(rng); });
    MarkerDetection d;
    d.hypotheses = detector.solvePose(corners);
    ASSERT_GE(d.hypotheses.size(), 1u);
    d.ambiguous = d.hypotheses.size() > 1 &&
                  d.hypotheses[1].reprojection_rms_px < 2.0 * d.hypotheses[0].reprojection_rms_px;
    detections.push_back(d);
    truths.push_back(truth);
  }
  int ambiguous = 0, best_fit_wrong = 0;
  auto tiltError = [](const Rigid3d& a, const Rigid3d& b) {
    return std::acos(std::clamp(
               (a.rotation * Eigen::Vector3d::UnitZ()).dot(b.rotation * Eigen::Vector3d::UnitZ()),
               -1.0, 1.0)) /
           kDeg;
  };
  // The right hypothesis of a frame: the one whose normal is nearer the truth's.
  auto right = [&](size_t i) {
    const auto& h = detections[i].hypotheses;
    if (h.size() < 2) return 0;
    return tiltError(h[1].camera_from_marker, truths[i]) <
                   tiltError(h[0].camera_from_marker, truths[i])
               ? 1
               : 0;
  };
  for (size_t i = 0; i < detections.size(); ++i) {
    ambiguous += detections[i].ambiguous ? 1 : 0;
    best_fit_wrong +=
        right(i) != 0 &&
                tiltError(detections[i].hypotheses[0].camera_from_marker, truths[i]) >
                    tiltError(detections[i].hypotheses[1].camera_from_marker, truths[i]) + 2.0
            ? 1
            : 0;
  }
  std::vector<MarkerDetection*> track;
  for (MarkerDetection& d : detections) track.push_back(&d);
  const int unresolved = resolveAmbiguity(track);
  int wrong = 0;
  for (size_t i = 0; i < detections.size(); ++i) {
    // Wrong: the chosen normal is clearly further from the truth than the other's.
    const auto& h = detections[i].hypotheses;
    wrong += tiltError(detections[i].pose().camera_from_marker, truths[i]) >
                     tiltError(h[static_cast<size_t>(right(i))].camera_from_marker, truths[i]) + 2.0
                 ? 1
                 : 0;
  }
  std::printf(
      "ambiguity: %d of %d frames ambiguous, best fit wrong in %d, after the track: %d "
      "wrong, %d unresolved\n",
      ambiguous, static_cast<int>(detections.size()), best_fit_wrong, wrong, unresolved);
  EXPECT_GE(best_fit_wrong, 3) << "the case is not exercised";
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(unresolved, 0);

  // One ambiguous detection alone cannot be resolved: flagged.
  MarkerDetection lone = detections.front();
  lone.ambiguous = true;
  std::vector<MarkerDetection*> single{&lone};
  EXPECT_EQ(resolveAmbiguity(single), 1);
  EXPECT_TRUE(lone.unresolved);
}

/// The simulator's rendering, with the background (not the robot) rendered
/// at one ray per pixel to keep the tests fast.
sim::RenderOptions fastRender() {
  sim::RenderOptions options;
  options.supersampling = 1;
  return options;
}

struct RenderedFrame {
  cv::Mat image;
  Rigid3d camera_from_marker;
};

/// Frames of a camera 3.0-3.8 m above the floor with the robot (marker at
/// 0.3 m) passing under it along a line, as the simulator renders them.
std::vector<RenderedFrame> renderPass(const Camera& camera, int frames, std::uint32_t seed,
                                      const MarkerSpec& marker = kMarker, int jump_frame = -1,
                                      double jump_m = 0) {
  sim::WorldSpec spec;
  spec.ceiling_min_m = 4.2;
  spec.ceiling_max_m = 4.8;
  const sim::World world(spec, 17);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const double height = 3.0 + 0.8 * u(rng);
  const double spin = 6.28 * u(rng);  // the last argument drawn first, as gcc did
  const double tilt = (1 + 3 * u(rng)) * kDeg;
  const double yaw = 6.28 * u(rng);
  const Rigid3d world_from_camera = lookingDown({20.0, 10.0, height}, yaw, tilt, spin);
  const double heading = 6.28 * u(rng);
  const Eigen::Vector2d along(std::cos(heading), std::sin(heading));
  std::vector<RenderedFrame> out;
  for (int i = 0; i < frames; ++i) {
    const double s = -1.2 + 2.4 * i / std::max(1, frames - 1);
    const Eigen::Vector2d across(-along.y(), along.x());
    const Eigen::Vector2d at =
        Eigen::Vector2d(20.0, 10.3) + s * along + (i == jump_frame ? jump_m : 0.0) * across;
    sim::RobotAppearance robot;
    robot.body_height_m = 0.30;
    robot.marker = marker;
    robot.world_from_base = Rigid3d(rotZ(heading), Eigen::Vector3d(at.x(), at.y(), 0.0));
    robot.world_from_marker = robot.world_from_base * Rigid3d(rotZ(-0.5 * 3.14159265358979),
                                                              Eigen::Vector3d(0.05, 0, 0.30));
    std::mt19937 noise(seed * 100 + static_cast<unsigned>(i));
    out.push_back(
        {sim::renderEnvCamera(world, camera, world_from_camera, robot, fastRender(), noise),
         world_from_camera.inverse() * robot.world_from_marker});
  }
  return out;
}

TEST(MarkerDetector, RenderedFramesAccuracyAndCorners) {
  // The paper's geometry at 1920x1080: corners refined by edge fitting sit
  // within a few hundredths of a pixel of the true projected corners, where
  // OpenCV's CORNER_REFINE_SUBPIX is biased by ~0.1 px (sim/render test).
  const Camera camera = envCamera();
  std::vector<double> corner_error, position_error, nees;
  int detected = 0, total = 0;
  const std::uint32_t first = testSeedBlock(1, 2);
  for (std::uint32_t pass = first; pass < first + 2; ++pass) {
    MarkerDetector detector(kMarker, camera);
    for (const RenderedFrame& f : renderPass(camera, 5, pass)) {
      bool in_view = true;  // the whole marker inside the image
      for (const Eigen::Vector2d& p : projectCorners(camera, f.camera_from_marker, 0.2))
        in_view = in_view && camera.isInImage(p, 10);
      if (!in_view) continue;
      ++total;
      const auto found = detector.detect(f.image);
      if (found.size() != 1) continue;
      ++detected;
      const auto truth_px = projectCorners(camera, f.camera_from_marker, 0.2);
      for (size_t k = 0; k < 4; ++k)
        corner_error.push_back((found[0].corners_px[k] - truth_px[k]).norm());
      // The hypothesis nearest the truth (the ambiguity is the track's job),
      // by NEES: the two hypotheses' positions can be a millimetre apart
      // while their tilts are not, and the flipped one's NEES is thousands.
      double best = 0, best_nees = 1e300;
      for (const MarkerPoseHypothesis& h : found[0].hypotheses) {
        const Eigen::Matrix<double, 6, 1> e = poseError(h.camera_from_marker, f.camera_from_marker);
        if (e.dot(h.information * e) < best_nees) {
          best = e.head<3>().norm();
          best_nees = e.dot(h.information * e);
        }
      }
      position_error.push_back(best);
      nees.push_back(best_nees);
    }
  }
  const double mean_nees =
      std::accumulate(nees.begin(), nees.end(), 0.0) / std::max<size_t>(1, nees.size());
  std::printf(
      "rendered 1920x1080: %d/%d detected; corner error median %.3f px, p90 %.3f px; "
      "position error median %.1f mm, max %.1f mm; mean NEES %.2f\n",
      detected, total, medianOf(corner_error), quantileOf(corner_error, 0.9),
      1000 * medianOf(position_error), 1000 * quantileOf(position_error, 1.0), mean_nees);
  EXPECT_EQ(detected, total);
  EXPECT_LT(medianOf(corner_error), 0.08);
  EXPECT_LT(medianOf(position_error), 0.005);
  // NEES of the real pipeline (corner noise from the renderer's blur, noise
  // and anti-aliasing, not from the assumed Gaussian): mean within [2, 12],
  // a factor of 2 around 6 given 10 frames (doc/benchmarks.md has the figure
  // on whole datasets).
  EXPECT_GT(mean_nees, 2.0);
  EXPECT_LT(mean_nees, 12.0);
}

TEST(MarkerDetector, FisheyeEnvironmentCamera) {
  // An environment camera with a fisheye lens (Kannala-Brandt): the edges are
  // curved in the image; fitting great circles through the model keeps the
  // corners exact.
  const Camera camera = fisheyeEnvCamera();
  MarkerDetector detector(kMarker, camera);
  std::vector<double> position_error;
  int detected = 0, total = 0;
  for (const RenderedFrame& f : renderPass(camera, 4, testSeed(21))) {
    ++total;
    const auto found = detector.detect(f.image);
    if (found.size() != 1) continue;
    ++detected;
    double best = 1e300;
    for (const MarkerPoseHypothesis& h : found[0].hypotheses)
      best = std::min(best, poseError(h.camera_from_marker, f.camera_from_marker).head<3>().norm());
    position_error.push_back(best);
  }
  std::printf("fisheye environment camera: %d/%d detected, position error median %.1f mm\n",
              detected, total, 1000 * medianOf(position_error));
  EXPECT_GE(detected, total - 1);
  EXPECT_LT(medianOf(position_error), 0.02);
}

void drawDecoy(cv::Mat& image, int id, const cv::Point2f& centre, float side) {
  cv::Mat bitmap;
  cv::aruco::drawMarker(cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50), id,
                        static_cast<int>(side), bitmap, 1);
  cv::copyMakeBorder(bitmap, bitmap, 10, 10, 10, 10, cv::BORDER_CONSTANT, 255);
  bitmap.copyTo(image(
      cv::Rect(static_cast<int>(centre.x), static_cast<int>(centre.y), bitmap.cols, bitmap.rows)));
}

TEST(MarkerDetector, OnlyTheManifestMarkerIsAccepted) {
  const Camera camera = envCamera();
  std::vector<RenderedFrame> frames = renderPass(camera, 2, 5);
  MarkerDetector detector(kMarker, camera);
  // Another id of the same dictionary in the frame: ignored.
  drawDecoy(frames[0].image, 3, {100, 100}, 90);
  const auto found = detector.detect(frames[0].image);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].marker_id, 7);
  EXPECT_LT(poseError(found[0].hypotheses[0].camera_from_marker, frames[0].camera_from_marker)
                .head<3>()
                .norm(),
            0.05);
  // The marker of another dictionary spec (id 3): not found in a frame of id 7 only.
  MarkerDetector other(MarkerSpec{"DICT_4X4_50", 3, 0.2}, camera);
  EXPECT_TRUE(other.detect(frames[1].image).empty());
}

TEST(MarkerDetector, LookAlikeWithTheSameIdIsRejectedByTheTrack) {
  // A look-alike of the robot's marker (same id, rendered like the real
  // one) 1.2 m to the side of the robot's path in one frame, where the robot
  // is hidden: its pose disagrees with the track before and after it.
  const Camera camera = envCamera();
  const std::vector<RenderedFrame> frames = renderPass(camera, 5, 8, kMarker, 2, 1.2);
  std::vector<std::pair<TimeNs, MarkerDetection>> track;
  MarkerDetector detector(kMarker, camera);
  for (size_t i = 0; i < frames.size(); ++i) {
    for (MarkerDetection& d : detector.detect(frames[i].image))
      track.emplace_back(static_cast<TimeNs>(i) * 500'000'000, std::move(d));  // ~1 m/s
  }
  ASSERT_EQ(track.size(), 5u);  // 4 true + the look-alike
  EXPECT_EQ(rejectTrackOutliers(track, 1.5, 1'000'000'000), 1);
  ASSERT_EQ(track.size(), 4u);
  for (const auto& [t, d] : track) EXPECT_NE(t, 1'000'000'000);
}

TEST(MarkerDetector, FramesWithoutTheRobot) {
  const Camera camera = envCamera();
  MarkerDetector detector(kMarker, camera);
  // Uniform, noise, and the floor without the robot.
  EXPECT_TRUE(detector.detect(cv::Mat(1080, 1920, CV_8UC1, cv::Scalar(128))).empty());
  cv::Mat noise(1080, 1920, CV_8UC1);
  cv::randu(noise, 0, 255);
  EXPECT_TRUE(detector.detect(noise).empty());
  sim::WorldSpec spec;
  const sim::World world(spec, 3);
  sim::RobotAppearance robot;  // far away, out of view
  robot.marker = kMarker;
  robot.world_from_base = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 1, 0));
  robot.world_from_marker = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 1, 0.3));
  std::mt19937 rng(1);
  const cv::Mat floor = sim::renderEnvCamera(
      world, camera, lookingDown({20, 10, 3.4}, 0.3, 0.03, 1.0), robot, fastRender(), rng);
  EXPECT_TRUE(detector.detect(floor).empty());
  // A wrong size is an error naming both sizes.
  EXPECT_THROW(detector.detect(cv::Mat(100, 100, CV_8UC1, cv::Scalar(0))), Error);
}

TEST(MarkerDetector, OpenCvTutorialPhotograph) {
  // A real photograph shipped by Debian's opencv-doc: OpenCV's ArUco tutorial
  // image singlemarkersoriginal.jpg (640x480, DICT_6X6_250). Reference ids and
  // corners from OpenCV's own test, opencv_contrib 4.6
  // modules/aruco/test/test_arucodetection.cpp, TEST(CV_ArucoTutorial,
  // can_find_singlemarkersoriginal), checked there to within 1 px.
  const std::filesystem::path photo =
      "/usr/share/doc/opencv-doc/opencv4/html/singlemarkersoriginal.jpg";
  if (!std::filesystem::exists(photo))
    GTEST_SKIP() << "opencv-doc is not installed (scripts/setup.sh)";
  const cv::Mat grey = cv::imread(photo.string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(grey.empty());
  const int ids[6] = {40, 98, 62, 23, 124, 203};
  const int gold[6][8] = {
      {359, 310, 404, 310, 410, 350, 362, 350}, {427, 255, 469, 256, 477, 289, 434, 288},
      {233, 273, 190, 273, 196, 241, 237, 241}, {298, 185, 334, 186, 335, 212, 297, 211},
      {425, 163, 430, 186, 394, 186, 390, 162}, {195, 155, 230, 155, 227, 178, 190, 178}};
  // The photo's calibration is unknown: a pinhole with a plausible focal length
  // (the corners do not depend on it; edges are fitted as straight lines).
  const Camera camera(PinholeModel{}, 640, 480, {600.0, 600.0, 319.5, 239.5});
  MarkerDetectorOptions options;
  options.max_reprojection_px = 100;  // the pose is meaningless without the calibration
  // The reference corners are integers (OpenCV's contour vertices, without
  // refinement): +-0.5 px of rounding on top of their own error. One of
  // ours (id 62, corner 2: y 239.9 against 241) is 1.1 px off; by inspection
  // of the photo that edge lies at y ~239.6, so we allow 1.2 px per axis and
  // require 23 of the 24 corners within 1 px.
  int found_all = 0, within_one = 0, corners = 0;
  double worst = 0;
  for (int m = 0; m < 6; ++m) {
    MarkerDetector detector(MarkerSpec{"DICT_6X6_250", ids[m], 0.05}, camera, options);
    const auto found = detector.detect(grey);
    ASSERT_EQ(found.size(), 1u) << "id " << ids[m];
    ++found_all;
    for (size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d offset =
          found[0].corners_px[k] - Eigen::Vector2d(gold[m][2 * k], gold[m][2 * k + 1]);
      worst = std::max(worst, offset.cwiseAbs().maxCoeff());
      ++corners;
      within_one += offset.cwiseAbs().maxCoeff() < 1.0 ? 1 : 0;
      EXPECT_LT(offset.cwiseAbs().maxCoeff(), 1.2) << "id " << ids[m] << " corner " << k;
    }
  }
  EXPECT_GE(within_one, 23);
  std::printf(
      "OpenCV tutorial photo: %d/6 ids found, %d/%d corners within 1 px of OpenCV's "
      "reference, worst %.2f px (per axis)\n",
      found_all, within_one, corners, worst);
}

// A marker OpenCV finds is never lost: where the edge fit fails (here a
// printed marker of 16 grey levels' contrast, under the fit's 20), its corners
// are OpenCV's refined by cornerSubPix, with a noise that says so, and the
// fallback is counted with its reason.
TEST(MarkerDetector, EdgeFitFailureFallsBackToOpenCvCorners) {
  const Camera camera(PinholeModel{}, 640, 480, {600.0, 600.0, 319.5, 239.5});
  cv::Mat image(480, 640, CV_8UC1, cv::Scalar(255));
  drawDecoy(image, 7, {250, 170}, 120);  // the marker at x 260..380, y 180..300
  cv::Mat faint;
  image.convertTo(faint, CV_8UC1, 16.0 / 255.0, 110.0);  // black 110, white 126
  cv::GaussianBlur(faint, faint, cv::Size(3, 3), 0.7);
  std::vector<std::vector<cv::Point2f>> opencv_corners;
  std::vector<int> opencv_ids;
  cv::aruco::detectMarkers(faint, cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50),
                           opencv_corners, opencv_ids);
  ASSERT_EQ(opencv_ids, std::vector<int>{7}) << "plain OpenCV must find it for this test";

  MarkerDetectorOptions options;
  options.max_reprojection_px = 100;  // no pose check: the photo-like frame has no true pose
  MarkerDetector detector(MarkerSpec{"DICT_4X4_50", 7, 0.2}, camera, options);
  const auto found = detector.detect(faint);
  ASSERT_EQ(found.size(), 1u) << "a marker OpenCV finds was lost";
  EXPECT_EQ(detector.stats().candidates, 1);
  EXPECT_EQ(detector.stats().fallbacks, 1);
  EXPECT_EQ(detector.stats().refined, 0);
  EXPECT_EQ(
      detector.stats().fallback_reasons.count("an edge of low contrast (under 20 grey levels)"),
      1u);
  EXPECT_GE(found[0].corner_sigma_px, options.fallback_corner_sigma_px);
  // The true corners (pixel centres): the marker's outer square, ArUco order.
  const Eigen::Vector2d truth[4] = {{259.5, 179.5}, {379.5, 179.5}, {379.5, 299.5}, {259.5, 299.5}};
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_LT((found[0].corners_px[k] - truth[k]).norm(), 1.5) << "corner " << k;
  }
  // The same frame at full contrast: the edge fit, no fallback.
  MarkerDetector sharp(MarkerSpec{"DICT_4X4_50", 7, 0.2}, camera, options);
  ASSERT_EQ(sharp.detect(image).size(), 1u);
  EXPECT_EQ(sharp.stats().refined, 1);
  EXPECT_EQ(sharp.stats().fallbacks, 0);
}

/// Text written to a file, for the dictionary file tests.
void writeText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path) << text;
}

// A dictionary the caller supplies in a file (OpenCV's FileStorage form)
// works as the predefined one MarkerSpec names: DICT_4X4_50 written out by
// OpenCV and read back finds the same marker at the same corners. A file
// that is no such dictionary, or lacks the id, is an error naming the file.
TEST(MarkerDetector, DictionaryFromAFile) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("lookboth_marker_dictionary_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  struct RemovedAtTheEnd {
    std::filesystem::path path;
    ~RemovedAtTheEnd() {
      std::error_code ignored;
      std::filesystem::remove_all(path, ignored);
    }
  } removed{dir};
  const std::filesystem::path file = dir / "dict_4x4_50.yml";
  {
    auto storage = cv::makePtr<cv::FileStorage>(file.string(), cv::FileStorage::WRITE);
    cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50)->writeDictionary(storage);
  }
  const Camera camera(PinholeModel{}, 640, 480, {600.0, 600.0, 319.5, 239.5});
  cv::Mat image(480, 640, CV_8UC1, cv::Scalar(255));
  drawDecoy(image, 7, {250, 170}, 120);
  MarkerDetectorOptions options;
  options.max_reprojection_px = 100;  // a drawn marker: no true pose
  MarkerDetector predefined(MarkerSpec{"DICT_4X4_50", 7, 0.2}, camera, options);
  MarkerDetector from_file = MarkerDetector::withDictionaryFile(file, 7, 0.2, camera, options);
  const auto expected = predefined.detect(image);
  const auto found = from_file.detect(image);
  ASSERT_EQ(expected.size(), 1u);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].marker_id, 7);
  for (size_t k = 0; k < 4; ++k) EXPECT_EQ(found[0].corners_px[k], expected[0].corners_px[k]);
  EXPECT_TRUE(MarkerDetector::withDictionaryFile(file, 3, 0.2, camera).detect(image).empty());

  const auto expectError = [&](const std::filesystem::path& path, int id, const std::string& why) {
    try {
      MarkerDetector::withDictionaryFile(path, id, 0.2, camera);
      ADD_FAILURE() << path << ": no error";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(path.string()), std::string::npos) << message;
      EXPECT_NE(message.find(why), std::string::npos) << message;
    }
  };
  expectError(dir / "missing.yml", 0, "cannot open");
  expectError(file, 50, "'id': 50 is not in this dictionary (ids 0..49)");
  writeText(dir / "broken.yml", "%YAML:1.0\nnmarkers: [2\n");
  expectError(dir / "broken.yml", 0, "cannot read it");
  writeText(dir / "list.yml", "%YAML:1.0\n---\n- 1\n- 2\n");
  expectError(dir / "list.yml", 0, "not an ArUco dictionary");
  writeText(dir / "no_size.yml", "%YAML:1.0\nnmarkers: 1\nmarker_0: \"1001\"\n");
  expectError(dir / "no_size.yml", 0, "'markersize'");
  // A marker of more bits than markersize^2 (OpenCV would write past its matrix).
  writeText(dir / "long.yml",
            "%YAML:1.0\nnmarkers: 2\nmarkersize: 2\nmarker_0: \"1001\"\nmarker_1: \"10011\"\n");
  expectError(dir / "long.yml", 0, "'marker_1'");
  writeText(dir / "short.yml", "%YAML:1.0\nnmarkers: 2\nmarkersize: 2\nmarker_0: \"1001\"\n");
  expectError(dir / "short.yml", 0, "'marker_1'");
  EXPECT_THROW(MarkerDetector::withDictionaryFile(file, 7, 0.0, camera), Error);
}

/// A photo whose calibration is unknown: a pinhole of plausible focal
/// length (the corners do not depend on it; no pose is checked).
Camera plausiblePinhole(const cv::Mat& grey) {
  const double f = 0.9 * grey.cols;
  return Camera(PinholeModel{}, grey.cols, grey.rows,
                {f, f, 0.5 * grey.cols - 0.5, 0.5 * grey.rows - 0.5});
}

// The ArUco photographs and pictures of Debian's opencv-doc (OpenCV's
// tutorials): each marker plain OpenCV finds (cv::aruco::detectMarkers,
// default parameters) in each dictionary, lookboth's detector finds too, as
// often. Which photo holds which dictionary was found by running plain OpenCV
// over the tutorial images with every dictionary. singlemarkersbrokenthresh.png
// is left out: it is a binary threshold map, not a picture of markers, in
// which plain OpenCV reads four outlines as ARUCO_ORIGINAL id 1023.
TEST(MarkerDetector, FindsEveryMarkerPlainOpenCvFindsInRealPhotos) {
  const std::filesystem::path html = "/usr/share/doc/opencv-doc/opencv4/html";
  if (!std::filesystem::exists(html / "singlemarkersoriginal.jpg"))
    GTEST_SKIP() << "opencv-doc is not installed (scripts/setup.sh)";
  int photos = 0, opencv_total = 0, ours_total = 0, fallbacks = 0;
  for (const char* name : {"singlemarkersoriginal.jpg", "singlemarkersdetection.jpg",
                           "singlemarkersaxes.jpg", "singlemarkersaxes2.jpg", "chaxis.jpg",
                           "screen_charuco.jpg", "markers.jpg", "board.jpg", "charucoboard.jpg"}) {
    const cv::Mat grey = cv::imread((html / name).string(), cv::IMREAD_GRAYSCALE);
    if (grey.empty()) continue;
    ++photos;
    const Camera camera = plausiblePinhole(grey);
    MarkerDetectorOptions options;
    options.max_reprojection_px = 100;
    options.detect_scale = 1;
    for (const char* dictionary_name : {"DICT_4X4_50", "DICT_6X6_250", "DICT_ARUCO_ORIGINAL"}) {
      std::vector<std::vector<cv::Point2f>> corners;
      std::vector<int> ids;
      cv::aruco::detectMarkers(
          grey, cv::aruco::getPredefinedDictionary(arucoDictionaryId(dictionary_name)), corners,
          ids);
      std::map<int, int> by_id;
      for (int id : ids) ++by_id[id];
      for (const auto& [id, count] : by_id) {
        MarkerDetector detector(MarkerSpec{dictionary_name, id, 0.05}, camera, options);
        const int found = static_cast<int>(detector.detect(grey).size());
        EXPECT_GE(found, count) << name << ": " << dictionary_name << " id " << id << " found "
                                << count << " times by plain OpenCV, " << found << " by lookboth";
        opencv_total += count;
        ours_total += std::min(found, count);
        fallbacks += static_cast<int>(detector.stats().fallbacks);
      }
    }
  }
  EXPECT_GE(photos, 9);
  EXPECT_GE(opencv_total, 80);
  std::printf(
      "opencv-doc pictures: %d; plain OpenCV %d markers, lookboth %d of them (%d by the "
      "fallback to OpenCV's corners)\n",
      photos, opencv_total, ours_total, fallbacks);
}

/// One tag of the AprilTag library's list: id and corners [px].
struct ListedTag {
  int id = 0;
  std::array<Eigen::Vector2d, 4> corners;
};

std::vector<ListedTag> readListedTags(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::vector<ListedTag> tags;
  std::string line;
  while (std::getline(in, line)) {
    for (char& c : line) {
      if (c == ',' || c == '(' || c == ')') c = ' ';
    }
    std::istringstream fields(line);
    ListedTag tag;
    if (!(fields >> tag.id)) continue;
    for (auto& corner : tag.corners) fields >> corner.x() >> corner.y();
    if (fields) tags.push_back(tag);
  }
  return tags;
}

/// Mean distance between two quadrilaterals' corners, over the corner
/// orders (the AprilTag library starts elsewhere and may turn the other way).
double quadDistance(const std::array<Eigen::Vector2d, 4>& a,
                    const std::array<Eigen::Vector2d, 4>& b) {
  double best = std::numeric_limits<double>::infinity();
  for (int shift = 0; shift < 4; ++shift) {
    for (int direction : {1, -1}) {
      double sum = 0;
      for (int k = 0; k < 4; ++k) sum += (a[k] - b[((shift + direction * k) % 4 + 4) % 4]).norm();
      best = std::min(best, sum / 4);
    }
  }
  return best;
}

// Printed (not backlit) tags photographed outdoors, 10-47 px on a side
// (tests/data/markers/apriltag_swarmathon/SOURCE.md): every tag plain
// OpenCV finds, ours finds too; against the AprilTag library's own list, the
// recall and the corners' agreement are measured.
TEST(MarkerDetector, FindsEveryTagPlainOpenCvFindsInRealAprilTagPhotos) {
  const std::filesystem::path dir =
      std::filesystem::path(LOOKBOTH_TEST_DATA_DIR) / "markers" / "apriltag_swarmathon";
  int opencv_total = 0, ours_total = 0, listed_total = 0, ours_listed = 0, opencv_listed = 0;
  std::vector<double> distances;
  for (const char* name :
       {"33369213973_9d9bb4cc96_c", "34085369442_304b6bafd9_c", "34139872896_defdb2f8d9_c"}) {
    const cv::Mat grey =
        cv::imread((dir / (std::string(name) + ".jpg")).string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(grey.empty()) << name;
    const std::vector<ListedTag> listed = readListedTags(dir / (std::string(name) + ".txt"));
    ASSERT_GE(listed.size(), 10u) << name;
    const Camera camera = plausiblePinhole(grey);
    MarkerDetectorOptions options;
    options.max_reprojection_px = 100;
    options.detect_scale = 1;
    // One tag, seen nearly edge-on, is 10.8 px on its short side by OpenCV's
    // corners and under the default's 10 px by ours (a pose from 1 px cells
    // is not worth having; the rejection is counted): recall is compared
    // with the size limit at its least.
    options.min_side_px = 4;
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::aruco::detectMarkers(
        grey, cv::aruco::getPredefinedDictionary(cv::aruco::DICT_APRILTAG_36h11), corners, ids);
    std::map<int, int> by_id;
    for (int id : ids) ++by_id[id];
    std::set<int> all_ids(ids.begin(), ids.end());
    for (const ListedTag& tag : listed) all_ids.insert(tag.id);
    std::vector<std::array<Eigen::Vector2d, 4>> ours, opencv;
    for (size_t k = 0; k < corners.size(); ++k) {
      std::array<Eigen::Vector2d, 4> quad;
      for (int c = 0; c < 4; ++c) quad[c] = Eigen::Vector2d(corners[k][c].x, corners[k][c].y);
      opencv.push_back(quad);
    }
    for (const int id : all_ids) {
      MarkerDetector detector(MarkerSpec{"DICT_APRILTAG_36h11", id, 0.1}, camera, options);
      const std::vector<MarkerDetection> found = detector.detect(grey);
      EXPECT_GE(static_cast<int>(found.size()), by_id[id])
          << name << ": id " << id << " found " << by_id[id] << " times by plain OpenCV, "
          << found.size() << " by lookboth";
      opencv_total += by_id[id];
      ours_total += std::min(static_cast<int>(found.size()), by_id[id]);
      for (const MarkerDetection& d : found) ours.push_back(d.corners_px);
    }
    // The same tags, not only as many: each of OpenCV's is one of ours.
    for (const auto& theirs : opencv) {
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& quad : ours) nearest = std::min(nearest, quadDistance(quad, theirs));
      EXPECT_LT(nearest, 3.0) << name << ": a tag plain OpenCV finds is not among ours";
    }
    for (const ListedTag& tag : listed) {
      ++listed_total;
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& quad : ours) nearest = std::min(nearest, quadDistance(quad, tag.corners));
      if (nearest < 3.0) {
        ++ours_listed;
        distances.push_back(nearest);
      }
      for (const auto& quad : opencv)
        opencv_listed += quadDistance(quad, tag.corners) < 3.0 ? 1 : 0;
    }
  }
  std::sort(distances.begin(), distances.end());
  const double median = distances.empty() ? 0 : distances[distances.size() / 2];
  std::printf(
      "AprilTag photos: plain OpenCV %d tags, lookboth %d of them; of the AprilTag library's %d, "
      "lookboth %d (corners %.2f px from its, median), plain OpenCV %d\n",
      opencv_total, ours_total, listed_total, ours_listed, median, opencv_listed);
  EXPECT_GE(opencv_total, 20);
  EXPECT_GT(opencv_listed, 0);
  EXPECT_GE(ours_listed, opencv_listed);
  EXPECT_LE(median, 1.0);
}

// Pose consistency where a board gives the reference: each marker of a
// board, with its place on the board, gives a pose of the whole board; the
// markers of one photo must agree with the board's pose fitted to all of
// them at once.

/// A calibration as OpenCV's matrices (camera_matrix, distortion k1 k2 p1 p2
/// k3) and as our radtan camera (the same model as cv::projectPoints with 5
/// coefficients).
struct OpenCvCalibration {
  cv::Mat camera_matrix, distortion;
  std::optional<Camera> camera;
};

OpenCvCalibration makeCalibration(const cv::Mat& camera_matrix, const cv::Mat& distortion,
                                  const cv::Size& size) {
  OpenCvCalibration out{camera_matrix.clone(), distortion.reshape(1, 1).clone(), std::nullopt};
  const cv::Mat& k = out.camera_matrix;
  const cv::Mat& d = out.distortion;
  if (k.size() != cv::Size(3, 3) || k.type() != CV_64F || d.total() != 5 || d.type() != CV_64F)
    return out;
  out.camera.emplace(RadTanModel{}, size.width, size.height,
                     std::vector<double>{k.at<double>(0, 0), k.at<double>(1, 1), k.at<double>(0, 2),
                                         k.at<double>(1, 2), d.at<double>(0), d.at<double>(1),
                                         d.at<double>(2), d.at<double>(3), d.at<double>(4)});
  return out;
}

/// An OpenCV FileStorage calibration (camera_matrix, distortion_coefficients).
OpenCvCalibration readOpenCvCalibration(const std::filesystem::path& path, const cv::Size& size) {
  cv::FileStorage storage(path.string(), cv::FileStorage::READ);
  cv::Mat k, d;
  storage["camera_matrix"] >> k;
  storage["distortion_coefficients"] >> d;
  return makeCalibration(k, d, size);
}

Rigid3d rigidFromOpenCv(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  cv::Matx33d r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d rotation;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) rotation(a, b) = r(a, b);
  return Rigid3d(Eigen::Quaterniond(rotation).normalized(),
                 Eigen::Vector3d(tvec[0], tvec[1], tvec[2]));
}

/// board_from_marker of one marker of an OpenCV board. Board::objPoints
/// lists a marker's corners in the order detectMarkers reports them (the
/// marker's top-left, top-right, bottom-right, bottom-left); our marker frame
/// puts those corners at (-s/2, s/2), (s/2, s/2), (s/2, -s/2), (-s/2, -s/2)
/// (MarkerDetection::corners_px, x right, y up, z out of the marker towards
/// the camera), as estimatePoseSingleMarkers does by default (CCW_center).
/// OpenCV 4.6's board frames have their origin at the first marker's
/// top-left corner, x right, y down the board and so z into it: the marker
/// frame is the board's turned by 180 degrees about x and moved to the
/// marker's centre. Rather than assume that, the motion is fitted (Umeyama,
/// no scale) to the four corner pairs; `residual_m` says how well it maps them.
Rigid3d boardFromMarker(const std::vector<cv::Point3f>& board_corners, double side,
                        double* residual_m) {
  Eigen::Matrix<double, 3, 4> marker, board;
  const double h = side / 2;
  marker << -h, h, h, -h, h, h, -h, -h, 0, 0, 0, 0;
  for (size_t k = 0; k < 4; ++k) {
    const cv::Point3f& c = board_corners[k];
    board.col(static_cast<int>(k)) = Eigen::Vector3d(c.x, c.y, c.z);
  }
  const Eigen::Matrix4d t = Eigen::umeyama(marker, board, false);
  const Rigid3d pose(Eigen::Quaterniond(Eigen::Matrix3d(t.topLeftCorner<3, 3>())).normalized(),
                     t.topRightCorner<3, 1>());
  *residual_m = 0;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d mapped = pose * Eigen::Vector3d(marker.col(k));
    *residual_m = std::max(*residual_m, (mapped - board.col(k)).norm());
  }
  return pose;
}

/// Points of a board photo (board coordinates, pixels) that fix the board's
/// pose independently of where any detector puts the markers' edges.
struct ReferencePoints {
  std::string name;
  std::vector<cv::Point3f> object;
  std::vector<cv::Point2f> image;
};

/// A photo of one of OpenCV's boards, and our detector for one marker id of
/// the board's dictionary with a given camera.
struct BoardPhoto {
  std::string name;
  cv::Mat grey;
  cv::Ptr<cv::aruco::Board> board;
  double marker_length = 0;  ///< [m], as the board was created with.
  std::function<MarkerDetector(int id, const Camera& camera)> ours;
  /// The reference points, found with a calibration.
  std::function<ReferencePoints(const OpenCvCalibration& calibration)> reference_points;
};

struct PlainMarkers {
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
};

PlainMarkers detectPlain(const BoardPhoto& photo, int corner_refinement) {
  auto parameters = cv::aruco::DetectorParameters::create();
  parameters->cornerRefinementMethod = corner_refinement;
  PlainMarkers out;
  cv::aruco::detectMarkers(photo.grey, photo.board->dictionary, out.corners, out.ids, parameters);
  return out;
}

/// The image of each board marker's centre, with its board coordinates:
/// where the marker's diagonals meet (a perspective map keeps lines and
/// their intersections), in undistorted coordinates, projected back through
/// the distortion. Printed squares grown or shrunk about their centres (ink
/// spread) leave it where it is, and so, nearly, do a detector's edges
/// offset evenly outwards or inwards.
ReferencePoints markerCentres(const BoardPhoto& photo, const PlainMarkers& markers,
                              const OpenCvCalibration& calibration) {
  ReferencePoints out{"marker centres", {}, {}};
  std::vector<cv::Point3d> centres;
  for (size_t i = 0; i < markers.ids.size(); ++i) {
    const auto at = std::find(photo.board->ids.begin(), photo.board->ids.end(), markers.ids[i]);
    if (at == photo.board->ids.end()) continue;
    const auto& corners =
        photo.board->objPoints[static_cast<size_t>(at - photo.board->ids.begin())];
    out.object.push_back(0.25f * (corners[0] + corners[1] + corners[2] + corners[3]));
    const std::vector<cv::Point2d> pixels(markers.corners[i].begin(), markers.corners[i].end());
    std::vector<cv::Point2d> normalised;
    cv::undistortPoints(pixels, normalised, calibration.camera_matrix, calibration.distortion);
    // Corners 0-2 and 1-3: p0 + a (p2 - p0) = p1 + b (p3 - p1).
    const cv::Point2d d0 = normalised[2] - normalised[0], d1 = normalised[3] - normalised[1];
    const cv::Point2d r = normalised[1] - normalised[0];
    const double a = (r.x * d1.y - r.y * d1.x) / (d0.x * d1.y - d0.y * d1.x);
    const cv::Point2d c = normalised[0] + a * d0;
    centres.emplace_back(c.x, c.y, 1.0);
  }
  if (centres.empty()) return out;
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(centres, cv::Vec3d::zeros(), cv::Vec3d::zeros(), calibration.camera_matrix,
                    calibration.distortion, pixels);
  out.image.assign(pixels.begin(), pixels.end());
  return out;
}

struct BoardFit {
  Rigid3d camera_from_board;
  double rms_px = 0;  ///< Reprojection error of the reference points.
};

/// The board's pose from its reference points (solvePnP over all of them);
/// nullopt with fewer than 4.
std::optional<BoardFit> fitBoard(const ReferencePoints& points,
                                 const OpenCvCalibration& calibration) {
  if (points.object.size() < 4) return std::nullopt;
  cv::Vec3d rvec, tvec;
  if (!cv::solvePnP(points.object, points.image, calibration.camera_matrix, calibration.distortion,
                    rvec, tvec))
    return std::nullopt;
  std::vector<cv::Point2f> projected;
  cv::projectPoints(points.object, rvec, tvec, calibration.camera_matrix, calibration.distortion,
                    projected);
  double squares = 0;
  for (size_t i = 0; i < projected.size(); ++i)
    squares += std::pow(cv::norm(projected[i] - points.image[i]), 2);
  return BoardFit{rigidFromOpenCv(rvec, tvec),
                  std::sqrt(squares / static_cast<double>(projected.size()))};
}

/// The photo's own calibration, fitted to its reference points in this one
/// view: one focal length (square pixels), k1 and k2; the principal point
/// kept from `guess` (one planar view cannot fix it).
OpenCvCalibration calibrateOnPhoto(const BoardPhoto& photo, const OpenCvCalibration& guess) {
  const ReferencePoints points = photo.reference_points(guess);
  cv::Mat k = guess.camera_matrix.clone(), d = cv::Mat::zeros(1, 5, CV_64F);
  std::vector<cv::Mat> rvecs, tvecs;
  cv::calibrateCamera(
      std::vector<std::vector<cv::Point3f>>{points.object},
      std::vector<std::vector<cv::Point2f>>{points.image}, photo.grey.size(), k, d, rvecs, tvecs,
      cv::CALIB_USE_INTRINSIC_GUESS | cv::CALIB_FIX_PRINCIPAL_POINT | cv::CALIB_FIX_ASPECT_RATIO |
          cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_FIX_K3);
  return makeCalibration(k, d, photo.grey.size());
}

/// One method's markers and their board poses against the reference.
struct MethodResult {
  std::string name;
  std::vector<int> ids;                  ///< Ids found, sorted.
  std::map<int, double> rotation_deg;    ///< Board pose's deviation, by board marker.
  std::map<int, double> translation_mm;  ///< Board pose's deviation, by board marker.
  std::map<int, double> side_mm;         ///< Mean side on the board's plane.
};

struct BoardPoseComparison {
  std::string reference_name;
  double reference_rms_px = 0;
  std::vector<MethodResult> opencv;  ///< Plain OpenCV: SUBPIX corners, then CONTOUR.
  MethodResult ours;
};

/// What a method found of marker `id` (its corners, its pose), against the reference.
void addMarker(MethodResult& result, int id, const std::array<Eigen::Vector2d, 4>& corners,
               const Rigid3d& camera_from_marker, const std::map<int, Rigid3d>& marker_from_board,
               const Rigid3d& reference, const Camera& camera) {
  result.ids.push_back(id);
  if (marker_from_board.count(id) == 0) return;
  const Rigid3d camera_from_board = camera_from_marker * marker_from_board.at(id);
  result.rotation_deg[id] =
      rotationAngleBetween(camera_from_board.rotation, reference.rotation) / kDeg;
  result.translation_mm[id] = 1000 * (camera_from_board.translation - reference.translation).norm();
  // The corners' rays met with the reference's board plane (z = 0).
  const Rigid3d board_from_camera = reference.inverse();
  std::array<Eigen::Vector3d, 4> on_board;
  for (size_t k = 0; k < 4; ++k) {
    const Eigen::Vector3d ray = board_from_camera.rotation * *camera.unproject(corners[k]);
    const Eigen::Vector3d& origin = board_from_camera.translation;
    on_board[k] = origin - origin.z() / ray.z() * ray;
  }
  double sides = 0;
  for (size_t k = 0; k < 4; ++k) sides += (on_board[(k + 1) % 4] - on_board[k]).norm();
  result.side_mm[id] = 1000 * sides / 4;
}

std::array<Eigen::Vector2d, 4> toEigen(const std::vector<cv::Point2f>& corners) {
  std::array<Eigen::Vector2d, 4> out;
  for (size_t k = 0; k < 4; ++k) out[k] = Eigen::Vector2d(corners[k].x, corners[k].y);
  return out;
}

/// Plain OpenCV: detectMarkers with the given corner refinement (default
/// parameters otherwise), then estimatePoseSingleMarkers.
MethodResult plainOpenCv(const BoardPhoto& photo, int refinement, const std::string& name,
                         const OpenCvCalibration& calibration,
                         const std::map<int, Rigid3d>& marker_from_board,
                         const Rigid3d& reference) {
  MethodResult out{name, {}, {}, {}, {}};
  const PlainMarkers plain = detectPlain(photo, refinement);
  if (plain.ids.empty()) return out;
  std::vector<cv::Vec3d> rvecs, tvecs;
  cv::aruco::estimatePoseSingleMarkers(plain.corners, static_cast<float>(photo.marker_length),
                                       calibration.camera_matrix, calibration.distortion, rvecs,
                                       tvecs);
  for (size_t i = 0; i < plain.ids.size(); ++i) {
    addMarker(out, plain.ids[i], toEigen(plain.corners[i]), rigidFromOpenCv(rvecs[i], tvecs[i]),
              marker_from_board, reference, *calibration.camera);
  }
  std::sort(out.ids.begin(), out.ids.end());
  return out;
}

/// Ours on every id of the board and every id plain OpenCV reported; the
/// best-fitting pose hypothesis (the photo alone decides: no track).
MethodResult ours(const BoardPhoto& photo, const OpenCvCalibration& calibration,
                  const std::map<int, Rigid3d>& marker_from_board, const Rigid3d& reference,
                  const std::vector<MethodResult>& opencv) {
  MethodResult out{"lookboth", {}, {}, {}, {}};
  std::set<int> tried(photo.board->ids.begin(), photo.board->ids.end());
  for (const MethodResult& peer : opencv) tried.insert(peer.ids.begin(), peer.ids.end());
  for (const int id : tried) {
    MarkerDetector detector = photo.ours(id, *calibration.camera);
    const auto found = detector.detect(photo.grey);
    if (found.empty()) continue;
    EXPECT_EQ(found.size(), 1u) << photo.name << ": id " << id;
    addMarker(out, id, found[0].corners_px, found[0].pose().camera_from_marker, marker_from_board,
              reference, *calibration.camera);
  }
  return out;
}

/// Each marker's pose composed with its place on the board, against the
/// board's pose from its reference points (the reference).
BoardPoseComparison compareBoardPoses(const BoardPhoto& photo,
                                      const OpenCvCalibration& calibration) {
  BoardPoseComparison out;
  const ReferencePoints reference_points = photo.reference_points(calibration);
  const auto reference_fit = fitBoard(reference_points, calibration);
  out.reference_name = reference_points.name;
  if (!reference_fit) {
    ADD_FAILURE() << photo.name << ": no reference pose from " << reference_points.name;
    return out;
  }
  const Rigid3d& reference = reference_fit->camera_from_board;
  out.reference_rms_px = reference_fit->rms_px;
  std::map<int, Rigid3d> marker_from_board;
  for (size_t i = 0; i < photo.board->ids.size(); ++i) {
    double residual = 0;
    marker_from_board[photo.board->ids[i]] =
        boardFromMarker(photo.board->objPoints[i], photo.marker_length, &residual).inverse();
    EXPECT_LT(residual, 1e-6) << "board marker " << photo.board->ids[i];
  }
  out.opencv.push_back(plainOpenCv(photo, cv::aruco::CORNER_REFINE_SUBPIX,
                                   "plain OpenCV, SUBPIX corners", calibration, marker_from_board,
                                   reference));
  out.opencv.push_back(plainOpenCv(photo, cv::aruco::CORNER_REFINE_CONTOUR,
                                   "plain OpenCV, CONTOUR corners", calibration, marker_from_board,
                                   reference));
  out.ours = ours(photo, calibration, marker_from_board, reference, out.opencv);
  return out;
}

/// Medians and maxima over the board markers every method found.
struct DeviationSummary {
  int markers = 0;
  double rotation_median_deg = 0, rotation_max_deg = 0;
  double translation_median_mm = 0, translation_max_mm = 0;
  double side_median_mm = 0;
};

DeviationSummary summarise(const MethodResult& result, const BoardPoseComparison& c) {
  std::vector<double> r, t, side;
  for (const auto& [id, value] : result.rotation_deg) {
    bool everywhere = c.ours.rotation_deg.count(id) == 1;
    for (const MethodResult& peer : c.opencv)
      everywhere = everywhere && peer.rotation_deg.count(id) == 1;
    if (!everywhere) continue;
    r.push_back(value);
    t.push_back(result.translation_mm.at(id));
    side.push_back(result.side_mm.at(id));
  }
  return {static_cast<int>(r.size()), medianOf(r),   quantileOf(r, 1.0), medianOf(t),
          quantileOf(t, 1.0),         medianOf(side)};
}

/// One line per method, for doc/benchmarks.md.
void printBoardPoses(const BoardPhoto& photo, const std::string& calibration_name,
                     const BoardPoseComparison& c, double nominal_side_mm) {
  std::printf("board photo %s, calibration %s: reference board pose from %s, %.2f px RMS\n",
              photo.name.c_str(), calibration_name.c_str(), c.reference_name.c_str(),
              c.reference_rms_px);
  std::vector<const MethodResult*> methods;
  for (const MethodResult& peer : c.opencv) methods.push_back(&peer);
  methods.push_back(&c.ours);
  for (const MethodResult* m : methods) {
    const DeviationSummary s = summarise(*m, c);
    std::printf(
        "  %-30s %2zu of %zu markers; board pose per marker (%d in common): rotation median "
        "%.2f max %.2f deg, translation median %.1f max %.1f mm; marker side on the board's "
        "plane %.2f mm (nominal %.0f)\n",
        m->name.c_str(), m->ids.size(), photo.board->ids.size(), s.markers, s.rotation_median_deg,
        s.rotation_max_deg, s.translation_median_mm, s.translation_max_mm, s.side_median_mm,
        nominal_side_mm);
  }
}

/// Every marker plain OpenCV finds, ours finds; none is off the board.
void expectBoardMarkersFound(const BoardPhoto& photo, const BoardPoseComparison& c) {
  const std::set<int> board(photo.board->ids.begin(), photo.board->ids.end());
  for (const int id : c.ours.ids) EXPECT_EQ(board.count(id), 1u) << "lookboth: id " << id;
  for (const MethodResult& peer : c.opencv) {
    for (const int id : peer.ids) {
      EXPECT_EQ(board.count(id), 1u) << peer.name << ": id " << id;
      EXPECT_TRUE(std::binary_search(c.ours.ids.begin(), c.ours.ids.end(), id))
          << photo.name << ": id " << id << " found by " << peer.name << ", not by lookboth";
    }
    EXPECT_GE(c.ours.ids.size(), peer.ids.size()) << peer.name;
  }
}

/// Bounds on our per-marker board poses' deviations.
struct BoardPoseBounds {
  double rotation_median_deg, rotation_max_deg, translation_median_mm;
};

void expectWithin(const BoardPoseComparison& c, const BoardPoseBounds& bounds) {
  const DeviationSummary s = summarise(c.ours, c);
  EXPECT_GE(s.markers, 4);
  EXPECT_LT(s.rotation_median_deg, bounds.rotation_median_deg);
  EXPECT_LT(s.rotation_max_deg, bounds.rotation_max_deg);
  EXPECT_LT(s.translation_median_mm, bounds.translation_median_mm);
}

const std::filesystem::path kOpenCvHtml = "/usr/share/doc/opencv-doc/opencv4/html";
const std::filesystem::path kOpenCvArucoExamples = "/usr/share/doc/opencv-doc/examples/aruco";

std::string describeCalibration(const OpenCvCalibration& calibration) {
  const std::vector<double>& p = calibration.camera->params();
  return "f " + formatFixed(p[0], 1) + " px, k1 " + formatFixed(p[4], 3) + ", k2 " +
         formatFixed(p[5], 3);
}

// OpenCV's board tutorial (tutorial_aruco_board_detection.html): a printed
// GridBoard 5x7, markers 0.04 m with 0.01 m between them, of the custom
// dictionary tutorial_dict.yml, and the tutorial's calibration
// tutorial_camera_params.yml. The reference is the board's pose from the
// markers' centres (the layout's pitch alone).
//
// That calibration does not fit the photo: the centres leave 2 px RMS with
// it, 0.5 px with a focal length and k1, k2 fitted on the photo itself
// (calibrateOnPhoto), so both are measured; the misfit roughly doubles every
// method's rotation deviations. And on the board's plane the printed squares
// measure 41.5 mm (our edges; OpenCV's SUBPIX corners agree on the near
// markers, where its window stays inside the border cells) for a pitch of
// 50 mm, not 40: single-marker poses with the nominal 40 mm come out ~3.5%
// near (~27 mm at 0.75 m), which dominates the translation deviations of a
// detector that finds the printed edges. The translation bound on ours
// allows for that, and so is looser than plain OpenCV's medians here
// (CONTOUR's corners sit ~0.5 px inside the edges, which offsets the bias).
TEST(MarkerDetector, MarkersOfAGridBoardAgreeOnTheBoardsPose) {
  const std::filesystem::path dictionary_file = kOpenCvArucoExamples / "tutorial_dict.yml";
  BoardPhoto photo;
  photo.name = "gboriginal.png";
  photo.grey = cv::imread((kOpenCvHtml / photo.name).string(), cv::IMREAD_GRAYSCALE);
  if (photo.grey.empty() || !std::filesystem::exists(dictionary_file))
    GTEST_SKIP() << "opencv-doc is not installed (scripts/setup.sh)";
  cv::FileStorage storage(dictionary_file.string(), cv::FileStorage::READ);
  auto dictionary = cv::makePtr<cv::aruco::Dictionary>();
  ASSERT_TRUE(dictionary->readDictionary(storage.root()));
  photo.marker_length = 0.04;
  photo.board = cv::aruco::GridBoard::create(5, 7, 0.04f, 0.01f, dictionary);
  photo.ours = [&](int id, const Camera& camera) {
    return MarkerDetector::withDictionaryFile(dictionary_file, id, photo.marker_length, camera);
  };
  const PlainMarkers unrefined = detectPlain(photo, cv::aruco::CORNER_REFINE_NONE);
  photo.reference_points = [&](const OpenCvCalibration& calibration) {
    return markerCentres(photo, unrefined, calibration);
  };
  const OpenCvCalibration tutorial =
      readOpenCvCalibration(kOpenCvArucoExamples / "tutorial_camera_params.yml", photo.grey.size());
  ASSERT_TRUE(tutorial.camera);
  const OpenCvCalibration own = calibrateOnPhoto(photo, tutorial);
  ASSERT_TRUE(own.camera);
  const BoardPoseComparison with_tutorial = compareBoardPoses(photo, tutorial);
  printBoardPoses(photo, "tutorial_camera_params.yml", with_tutorial, 40);
  const BoardPoseComparison with_own = compareBoardPoses(photo, own);
  printBoardPoses(photo, "fitted on the photo (" + describeCalibration(own) + ")", with_own, 40);
  expectBoardMarkersFound(photo, with_tutorial);
  expectBoardMarkersFound(photo, with_own);
  // Measured: rotation median 1.98 / 1.04 deg, max 6.63 / 3.03 deg;
  // translation median 26.9 / 28.1 mm (tutorial's / fitted calibration).
  // Plain OpenCV's SUBPIX medians: 4.80 / 2.97 deg. A flipped pose (the
  // other IPPE hypothesis) deviates by 70-110 degrees here.
  expectWithin(with_tutorial, {3.0, 10.0, 40.0});
  expectWithin(with_own, {1.6, 5.0, 40.0});
}

/// The corners between the chessboard's squares of a ChArUco board, found
/// around the markers plain OpenCV finds (interpolateCornersCharuco, which
/// refines them with cornerSubPix): saddle points, which no detector's
/// marker edges enter.
ReferencePoints chessboardCorners(const BoardPhoto& photo, const PlainMarkers& markers,
                                  const cv::Ptr<cv::aruco::CharucoBoard>& board,
                                  const OpenCvCalibration& calibration) {
  ReferencePoints out{"chessboard corners", {}, {}};
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(markers.corners, markers.ids, photo.grey, board, out.image,
                                       ids, calibration.camera_matrix, calibration.distortion);
  for (const int id : ids) out.object.push_back(board->chessboardCorners[static_cast<size_t>(id)]);
  return out;
}

// OpenCV's ChArUco tutorial (tutorial_charuco_detection.html): a printed
// CharucoBoard 5x7, squares 0.04 m, markers 0.02 m, DICT_6X6_250, and the
// tutorial's calibration tutorial_camera_charuco.yml, which fits this photo
// (0.2 px RMS on the chessboard corners). The photo is choriginal.jpg, the
// one the tutorial's detect_board_charuco command line names; chaxis.jpg is
// the same photo with axes and ids drawn over the board, which leave plain
// OpenCV three of its 17 markers. The reference is the board's pose from the
// chessboard corners, which no marker detector's edges enter.
TEST(MarkerDetector, MarkersOfAChArUcoBoardAgreeOnTheBoardsPose) {
  BoardPhoto photo;
  photo.name = "choriginal.jpg";
  photo.grey = cv::imread((kOpenCvHtml / photo.name).string(), cv::IMREAD_GRAYSCALE);
  const std::filesystem::path calibration_file =
      kOpenCvArucoExamples / "tutorial_camera_charuco.yml";
  if (photo.grey.empty() || !std::filesystem::exists(calibration_file))
    GTEST_SKIP() << "opencv-doc is not installed (scripts/setup.sh)";
  const auto board = cv::aruco::CharucoBoard::create(
      5, 7, 0.04f, 0.02f, cv::aruco::getPredefinedDictionary(cv::aruco::DICT_6X6_250));
  photo.board = board;
  photo.marker_length = 0.02;
  photo.ours = [&](int id, const Camera& camera) {
    return MarkerDetector(MarkerSpec{"DICT_6X6_250", id, photo.marker_length}, camera);
  };
  const PlainMarkers unrefined = detectPlain(photo, cv::aruco::CORNER_REFINE_NONE);
  photo.reference_points = [&](const OpenCvCalibration& calibration) {
    return chessboardCorners(photo, unrefined, board, calibration);
  };
  const OpenCvCalibration tutorial = readOpenCvCalibration(calibration_file, photo.grey.size());
  ASSERT_TRUE(tutorial.camera);
  const BoardPoseComparison c = compareBoardPoses(photo, tutorial);
  printBoardPoses(photo, "tutorial_camera_charuco.yml", c, 20);
  expectBoardMarkersFound(photo, c);
  EXPECT_LT(c.reference_rms_px, 0.5) << "the calibration does not fit the photo";
  // Measured: rotation median 1.27 deg, max 4.27 deg, translation median
  // 4.1 mm; plain OpenCV's SUBPIX medians 6.60 deg, 32.4 mm.
  expectWithin(c, {2.0, 7.0, 7.0});
}

}  // namespace
}  // namespace lookboth
