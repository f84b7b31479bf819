// Rendering through the camera models: the environment cameras' marker
// frames must give plain OpenCV ArUco the marker pose within 1 cm / 0.5 deg,
// the fisheye must see the housings where the ground truth projects, with
// texture for visual odometry, and frames are deterministic.
#include "lookboth/sim/render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"

namespace lookboth::sim {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Camera envCamera() {
  return loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/ceiling_camera_ros.yaml");
}
Camera fisheyeCamera() {
  return loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_calib_results.txt");
}

/// Writes an image for inspection when LOOKBOTH_RENDER_DUMP names a folder.
void dump(const cv::Mat& image, const std::string& name) {
  const char* folder = std::getenv("LOOKBOTH_RENDER_DUMP");
  if (folder && *folder) cv::imwrite(std::string(folder) + "/" + name + ".png", image);
}

double seconds(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

Eigen::Quaterniond rotZ(double angle) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()));
}

/// A camera looking down: camera x along world x, y along -y, z along -z,
/// then tilted by `tilt` about a horizontal axis at `tilt_direction` and
/// turned by `yaw` about the vertical.
Rigid3d lookingDown(const Eigen::Vector3d& position, double yaw, double tilt,
                    double tilt_direction) {
  const Eigen::Quaterniond down(Eigen::Matrix3d(Eigen::Vector3d(1, -1, -1).asDiagonal()));
  const Eigen::Vector3d axis(std::cos(tilt_direction), std::sin(tilt_direction), 0.0);
  return Rigid3d(rotZ(yaw) * Eigen::Quaterniond(Eigen::AngleAxisd(tilt, axis)) * down, position);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct Lcg {
  std::uint64_t state;
  double uniform(double a, double b) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return a + (b - a) * static_cast<double>(state >> 11) * 0x1.0p-53;
  }
};

// ---------------------------------------------------------------- options and markers

TEST(RenderOptions, CheckNamesTheField) {
  EXPECT_EQ(RenderOptions{}.check(), "");
  RenderOptions o;
  o.supersampling = 0;
  EXPECT_NE(o.check().find("supersampling"), std::string::npos);
  o = RenderOptions{};
  o.exposure = 0.0;
  EXPECT_NE(o.check().find("exposure"), std::string::npos);
  o = RenderOptions{};
  o.noise_sigma = -1.0;
  EXPECT_NE(o.check().find("noise_sigma"), std::string::npos);
  o = RenderOptions{};
  o.motion_blur_px = std::nan("");
  EXPECT_NE(o.check().find("motion_blur_px"), std::string::npos);
  World world(WorldSpec{}, 1);
  std::mt19937 rng(1);
  o.motion_blur_px = -2.0;
  EXPECT_THROW(renderFisheye(world, fisheyeCamera(), Rigid3d(), o, rng), Error);
}

TEST(MarkerCells, AreTheDictionaryBitmap) {
  const MarkerSpec spec{"DICT_4X4_50", 7, 0.2};
  const cv::Mat cells = markerCells(spec);
  ASSERT_EQ(cells.rows, 6);
  ASSERT_EQ(cells.cols, 6);
  cv::Mat drawn;
  cv::aruco::drawMarker(cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50), 7, 6, drawn, 1);
  EXPECT_EQ(cv::norm(cells, drawn, cv::NORM_INF), 0.0);
  for (int k = 0; k < 6; ++k) {  // the border is black
    EXPECT_EQ(cells.at<std::uint8_t>(0, k), 0);
    EXPECT_EQ(cells.at<std::uint8_t>(5, k), 0);
    EXPECT_EQ(cells.at<std::uint8_t>(k, 0), 0);
    EXPECT_EQ(cells.at<std::uint8_t>(k, 5), 0);
  }
  EXPECT_EQ(arucoDictionaryId("DICT_APRILTAG_36h11"), cv::aruco::DICT_APRILTAG_36h11);
  EXPECT_THROW(arucoDictionaryId("DICT_9X9_50"), Error);
  EXPECT_THROW(markerCells(MarkerSpec{"DICT_4X4_50", 50, 0.2}), Error);
}

// ---------------------------------------------------------------- environment cameras

/// A rendered marker frame and its ground truth.
struct MarkerFrame {
  cv::Mat image;
  Rigid3d camera_from_marker;
};

constexpr int kMarkerId = 3;
constexpr double kMarkerSide = 0.2;

/// Frames of a camera `height` above the floor, looking down with 2-5 deg of
/// tilt, the robot (marker at 0.3 m, lying on the top plate) at random yaws
/// and at random positions up to `max_offset` m from the camera's nadir (0:
/// anywhere in the image), the whole marker panel in the image.
std::vector<MarkerFrame> renderMarkerFrames(const World& world, const Camera& camera, double height,
                                            int frames, double max_offset, Lcg& rng) {
  const Rigid3d world_from_camera =
      lookingDown({20.0, 10.0, height}, rng.uniform(-3.1, 3.1), rng.uniform(2.0, 5.0) * kDeg,
                  rng.uniform(-3.1, 3.1));
  const double marker_height = 0.30;
  std::vector<MarkerFrame> out;
  for (int attempt = 0; static_cast<int>(out.size()) < frames && attempt < 50 * frames; ++attempt) {
    Eigen::Vector2d at;
    if (max_offset > 0.0) {
      const double r = max_offset * std::sqrt(rng.uniform(0.0, 1.0)), a = rng.uniform(-3.2, 3.2);
      at = world_from_camera.translation.head<2>() + r * Eigen::Vector2d(std::cos(a), std::sin(a));
    } else {  // under a random pixel
      const std::optional<Eigen::Vector3d> bearing = camera.unproject(Eigen::Vector2d(
          rng.uniform(60, camera.width() - 60), rng.uniform(60, camera.height() - 60)));
      if (!bearing) continue;
      const Eigen::Vector3d d = world_from_camera.rotation * *bearing;
      at = (world_from_camera.translation + (marker_height - height) / d.z() * d).head<2>();
    }
    RobotAppearance robot;
    robot.body_height_m = marker_height;
    robot.marker = MarkerSpec{"DICT_4X4_50", kMarkerId, kMarkerSide};
    robot.world_from_base =
        Rigid3d(rotZ(rng.uniform(-3.1, 3.1)), Eigen::Vector3d(at.x(), at.y(), 0.0));
    // The marker lies on the top plate (coplanar with it), its y axis forward.
    const Rigid3d base_from_marker(rotZ(-0.5 * 3.14159265358979323846),
                                   Eigen::Vector3d(0.05, 0.0, marker_height));
    robot.world_from_marker = robot.world_from_base * base_from_marker;
    const Rigid3d camera_from_marker = world_from_camera.inverse() * robot.world_from_marker;
    bool visible = true;  // the whole panel (side 1.4 x 0.2 m) well inside the image
    for (double sx : {-1.0, 1.0}) {
      for (double sy : {-1.0, 1.0}) {
        const auto px =
            camera.project(camera_from_marker * Eigen::Vector3d(sx * 0.14, sy * 0.14, 0.0));
        visible = visible && px && camera.isInImage(*px, 8.0);
      }
    }
    if (!visible) continue;
    std::mt19937 noise(static_cast<unsigned>(attempt));
    out.push_back({renderEnvCamera(world, camera, world_from_camera, robot, RenderOptions{}, noise),
                   camera_from_marker});
  }
  EXPECT_EQ(static_cast<int>(out.size()), frames) << "could not place the robot";
  return out;
}

struct MarkerStats {
  std::vector<double> position_error, along_sight, in_plane_deg, tilt_deg, distance;
  std::vector<double> corner_error_px, corner_outward_px;  ///< Detected - projected true corners.
  std::vector<Eigen::Vector2d> corner_offset_px;
  int visible = 0, detected = 0, false_detections = 0;

  void add(const MarkerStats& o) {
    for (auto v : {&MarkerStats::position_error, &MarkerStats::along_sight,
                   &MarkerStats::in_plane_deg, &MarkerStats::tilt_deg, &MarkerStats::distance,
                   &MarkerStats::corner_error_px, &MarkerStats::corner_outward_px}) {
      (this->*v).insert((this->*v).end(), (o.*v).begin(), (o.*v).end());
    }
    corner_offset_px.insert(corner_offset_px.end(), o.corner_offset_px.begin(),
                            o.corner_offset_px.end());
    visible += o.visible;
    detected += o.detected;
    false_detections += o.false_detections;
  }
  double maxOf(const std::vector<double>& v) const {
    return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
  }
  void print(const std::string& title) const {
    Eigen::Vector2d mean_offset = Eigen::Vector2d::Zero();
    for (const Eigen::Vector2d& o : corner_offset_px)
      mean_offset += o / std::max<std::size_t>(1, corner_offset_px.size());
    std::printf(
        "%s, marker %.2f-%.2f m away: position error median %.1f max %.1f mm (along the line of "
        "sight median "
        "%+.1f mm); in-plane rotation median %.3f max %.3f deg; tilt median %.2f max %.2f deg; "
        "recall %d/%d; "
        "corners: error median %.3f px, mean outward %+.3f px, mean offset (%+.3f, %+.3f) px\n",
        title.c_str(), distance.empty() ? 0.0 : *std::min_element(distance.begin(), distance.end()),
        maxOf(distance), 1000 * median(position_error), 1000 * maxOf(position_error),
        1000 * median(along_sight), median(in_plane_deg), maxOf(in_plane_deg), median(tilt_deg),
        maxOf(tilt_deg), detected, visible, median(corner_error_px),
        std::accumulate(corner_outward_px.begin(), corner_outward_px.end(), 0.0) /
            std::max<std::size_t>(1, corner_outward_px.size()),
        mean_offset.x(), mean_offset.y());
  }
};

/// Plain OpenCV: detectMarkers with the given corner refinement, then
/// solvePnP (IPPE_SQUARE) with the calibration's radtan coefficients.
MarkerStats scoreMarkerFrames(const std::vector<MarkerFrame>& frames, const Camera& camera,
                              int refinement) {
  const std::vector<double>& p = camera.params();
  const cv::Matx33d K(p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
  const std::vector<double> distortion = {p[4], p[5], p[6], p[7], p[8]};
  const cv::Ptr<cv::aruco::Dictionary> dictionary =
      cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
  cv::Ptr<cv::aruco::DetectorParameters> parameters = cv::aruco::DetectorParameters::create();
  parameters->cornerRefinementMethod = refinement;
  parameters->cornerRefinementMinAccuracy = 0.01;  // the default 0.1 px stops early
  parameters->cornerRefinementMaxIterations = 100;
  const float h = static_cast<float>(kMarkerSide / 2);
  const std::vector<cv::Point3f> object = {cv::Point3f(-h, h, 0), cv::Point3f(h, h, 0),
                                           cv::Point3f(h, -h, 0), cv::Point3f(-h, -h, 0)};
  MarkerStats stats;
  for (const MarkerFrame& frame : frames) {
    ++stats.visible;
    std::vector<std::vector<cv::Point2f>> corners, rejected;
    std::vector<int> ids;
    cv::aruco::detectMarkers(frame.image, dictionary, corners, ids, parameters, rejected);
    const auto it = std::find(ids.begin(), ids.end(), kMarkerId);
    stats.false_detections += static_cast<int>(ids.size()) - (it == ids.end() ? 0 : 1);
    if (it == ids.end()) {
      dump(frame.image, "missed_" + std::to_string(stats.visible));
      continue;
    }
    ++stats.detected;
    const std::vector<cv::Point2f>& c = corners[static_cast<std::size_t>(it - ids.begin())];
    // Corner errors against the true corners projected by the camera model.
    std::vector<Eigen::Vector2d> truth_px;
    Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
    for (const cv::Point3f& o : object) {
      truth_px.push_back(
          *camera.project(frame.camera_from_marker * Eigen::Vector3d(o.x, o.y, o.z)));
      centre_px += 0.25 * truth_px.back();
    }
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d e =
          Eigen::Vector2d(c[static_cast<std::size_t>(k)].x, c[static_cast<std::size_t>(k)].y) -
          truth_px[static_cast<std::size_t>(k)];
      stats.corner_error_px.push_back(e.norm());
      stats.corner_offset_px.push_back(e);
      stats.corner_outward_px.push_back(
          e.dot((truth_px[static_cast<std::size_t>(k)] - centre_px).normalized()));
    }
    cv::Vec3d rvec, tvec;
    EXPECT_TRUE(
        cv::solvePnP(object, c, K, distortion, rvec, tvec, false, cv::SOLVEPNP_IPPE_SQUARE));
    cv::Matx33d r;
    cv::Rodrigues(rvec, r);
    Eigen::Matrix3d estimated;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) estimated(i, j) = r(i, j);
    }
    const Eigen::Vector3d& truth_t = frame.camera_from_marker.translation;
    const Eigen::Vector3d error = Eigen::Vector3d(tvec[0], tvec[1], tvec[2]) - truth_t;
    stats.position_error.push_back(error.norm());
    if (std::getenv("LOOKBOTH_RENDER_VERBOSE")) {
      std::printf(
          "  refinement %d: %.2f m away, %.0f deg off axis: error %.1f mm, along sight %+.1f mm; "
          "corners",
          refinement, truth_t.norm(), std::acos(truth_t.normalized().z()) / kDeg,
          1000 * error.norm(), 1000 * error.dot(truth_t.normalized()));
      for (auto o = stats.corner_offset_px.end() - 4; o != stats.corner_offset_px.end(); ++o) {
        std::printf(" (%+.2f, %+.2f)", o->x(), o->y());
      }
      std::printf(" px\n");
    }
    stats.along_sight.push_back(error.dot(truth_t.normalized()));
    stats.distance.push_back(truth_t.norm());
    // The estimate in the true marker frame: in-plane rotation about z, tilt of z.
    const Eigen::Matrix3d relative =
        frame.camera_from_marker.rotation.toRotationMatrix().transpose() * estimated;
    stats.in_plane_deg.push_back(std::abs(std::atan2(relative(1, 0), relative(0, 0))) / kDeg);
    stats.tilt_deg.push_back(std::acos(std::clamp(relative(2, 2), -1.0, 1.0)) / kDeg);
  }
  return stats;
}

TEST(RenderEnvCamera, MarkerEdgesLieWhereTheModelProjectsThem) {
  // Rendering itself is unbiased: on a pinhole camera looking straight down,
  // the anti-aliased edges of the black square, located by integrating the
  // pixel coverage along rows, sit where the true edges project.
  const Camera camera(PinholeModel{}, 400, 300, {400.0, 400.0, 199.5, 149.5});
  WorldSpec spec;
  spec.ceiling_min_m = 4.2;
  spec.ceiling_max_m = 4.8;
  const World world(spec, 4);
  const Eigen::Vector3d eye(20.0, 10.0, 2.3);
  const Rigid3d world_from_camera = lookingDown(eye, 0.0, 0.0, 0.0);
  const Eigen::Vector3d marker_centre(20.0137, 9.9821, 0.3);  // edges at fractional pixels
  RobotAppearance robot;
  robot.world_from_base = Rigid3d(Eigen::Quaterniond::Identity(),
                                  Eigen::Vector3d(marker_centre.x(), marker_centre.y(), 0));
  robot.world_from_marker = Rigid3d(Eigen::Quaterniond::Identity(), marker_centre);
  robot.marker = MarkerSpec{"DICT_4X4_50", kMarkerId, kMarkerSide};
  RenderOptions options;
  options.noise_sigma = 0.0;
  options.blur_sigma_px = 0.0;
  options.vignetting = 0.0;
  options.marker_supersampling = 16;
  std::mt19937 rng(1);
  const cv::Mat image = renderEnvCamera(world, camera, world_from_camera, robot, options, rng);
  dump(image, "marker_pinhole");
  // True edges: camera x = world x, the marker 2 m below.
  const double z = eye.z() - marker_centre.z();
  const double left = 400.0 * (marker_centre.x() - 0.1 - eye.x()) / z + 199.5;
  const double right = 400.0 * (marker_centre.x() + 0.1 - eye.x()) / z + 199.5;
  const double v_centre = 400.0 * -(marker_centre.y() - eye.y()) / z + 149.5;
  const double white =
      image.at<std::uint8_t>(static_cast<int>(v_centre), static_cast<int>(left) - 3);
  const double black =
      image.at<std::uint8_t>(static_cast<int>(v_centre), static_cast<int>(left) + 3);
  ASSERT_GT(white - black, 150.0);
  double worst = 0.0;
  for (int v = static_cast<int>(v_centre) - 8; v <= static_cast<int>(v_centre) + 8; ++v) {
    // Left edge: white -> black; x = (first pixel - 0.5) + sum of white fractions.
    const int a = static_cast<int>(std::floor(left)) - 2,
              b = static_cast<int>(std::floor(left)) + 3;
    double sum = 0.0;
    for (int u = a; u <= b; ++u) sum += (image.at<std::uint8_t>(v, u) - black) / (white - black);
    const double left_found = a - 0.5 + sum;
    // Right edge: black -> white; x = (last pixel + 0.5) - sum of white fractions.
    const int c = static_cast<int>(std::floor(right)) - 2,
              d = static_cast<int>(std::floor(right)) + 3;
    sum = 0.0;
    for (int u = c; u <= d; ++u) sum += (image.at<std::uint8_t>(v, u) - black) / (white - black);
    const double right_found = d + 0.5 - sum;
    worst = std::max({worst, std::abs(left_found - left), std::abs(right_found - right)});
  }
  std::printf("pinhole marker edges: worst offset %.4f px over 17 rows\n", worst);
  EXPECT_LT(worst, 0.02);
}

TEST(RenderEnvCamera, PlainArucoRecoversTheMarkerPose) {
  // The paper's distances: cameras 3.0-3.8 m above the floor looking down
  // with a few degrees of tilt, the robot passing within 2.5 m of the nadir
  // (43 cameras over ~800 m^2 with little overlap), a 0.2 m marker at 0.3 m:
  // 2.7-4.5 m away, up to ~40 deg off the optical axis.
  WorldSpec spec;  // a high ceiling: nothing between the cameras and the floor
  spec.ceiling_min_m = 4.2;
  spec.ceiling_max_m = 4.8;
  const World world(spec, 17);
  const Camera camera = envCamera();
  Lcg rng{99};
  const char* frames_env = std::getenv("LOOKBOTH_RENDER_MARKER_FRAMES");  // for studies
  const int frames = frames_env ? std::atoi(frames_env) : 12;
  const auto start = std::chrono::steady_clock::now();
  MarkerStats apriltag, subpix;
  for (double height : {3.0, 3.4, 3.8}) {
    const std::vector<MarkerFrame> rendered =
        renderMarkerFrames(world, camera, height, frames, 2.5, rng);
    dump(rendered.front().image, "env_h" + std::to_string(static_cast<int>(height * 10)));
    const MarkerStats a = scoreMarkerFrames(rendered, camera, cv::aruco::CORNER_REFINE_APRILTAG);
    const MarkerStats s = scoreMarkerFrames(rendered, camera, cv::aruco::CORNER_REFINE_SUBPIX);
    char title[64];
    std::snprintf(title, sizeof title, "camera at %.1f m, APRILTAG", height);
    a.print(title);
    std::snprintf(title, sizeof title, "camera at %.1f m, SUBPIX", height);
    s.print(title);
    apriltag.add(a);
    subpix.add(s);
  }
  std::printf("%d frames rendered and scored in %.1f s\n", apriltag.visible, seconds(start));
  apriltag.print("all, CORNER_REFINE_APRILTAG");
  subpix.print("all, CORNER_REFINE_SUBPIX");
  // Both refinements find every marker, and nothing else.
  for (const MarkerStats* s : {&apriltag, &subpix}) {
    EXPECT_EQ(s->detected, s->visible) << "recall";
    EXPECT_EQ(s->false_detections, 0);
    ASSERT_GT(s->detected, 0);
    EXPECT_LE(median(s->in_plane_deg), 0.5);
    EXPECT_LE(s->maxOf(s->in_plane_deg), 0.5);
  }
  // The done-when of the simulator: within 1 cm (median), with OpenCV's
  // AprilTag edge refinement (its corners carry OpenCV's +0.5 px offset, left
  // in). Its worst frames reach ~1.7 cm along the line of sight, with or
  // without noise: the refinement's own scatter (+-0.2 px per corner).
  EXPECT_LE(median(apriltag.position_error), 0.010);
  EXPECT_LE(apriltag.maxOf(apriltag.position_error), 0.025);
  // cornerSubPix is biased on the marker's convex corners (the images are
  // not: see MarkerEdgesLieWhereTheModelProjectsThem): the corners come out
  // ~0.12 px inside, the marker looks smaller, so ~0.3% of the distance
  // further away: ~1 cm at these distances. Measured, bounded, not hidden.
  EXPECT_LT(std::accumulate(subpix.corner_outward_px.begin(), subpix.corner_outward_px.end(), 0.0) /
                static_cast<double>(subpix.corner_outward_px.size()),
            -0.05);
  EXPECT_LE(median(subpix.position_error), 0.015);
  EXPECT_LE(subpix.maxOf(subpix.position_error), 0.030);
}

TEST(RenderEnvCamera, MarkerAccuracyAnywhereInTheImage) {
  // Beyond the paper's distances: the robot under any pixel of the image, up
  // to ~6 m away and 55 deg off axis where this lens compresses the marker to
  // ~4 px per cell. Printed for the record; only recall is asserted.
  WorldSpec spec;
  spec.ceiling_min_m = 4.2;
  spec.ceiling_max_m = 4.8;
  const World world(spec, 18);
  const Camera camera = envCamera();
  Lcg rng{7};
  const std::vector<MarkerFrame> rendered = renderMarkerFrames(world, camera, 3.4, 8, 0.0, rng);
  const MarkerStats a = scoreMarkerFrames(rendered, camera, cv::aruco::CORNER_REFINE_APRILTAG);
  const MarkerStats s = scoreMarkerFrames(rendered, camera, cv::aruco::CORNER_REFINE_SUBPIX);
  a.print("anywhere, camera at 3.4 m, APRILTAG");
  s.print("anywhere, camera at 3.4 m, SUBPIX");
  EXPECT_EQ(a.detected, a.visible);
  EXPECT_EQ(s.detected, s.visible);
}

TEST(RenderEnvCamera, BlackWhereTheModelHasNoRay) {
  const Camera camera = envCamera();
  const World world(WorldSpec{}, 2);
  RobotAppearance robot;
  robot.world_from_base = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(20, 10, 0));
  robot.world_from_marker = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(20, 10, 0.25));
  std::mt19937 rng(3);
  const cv::Mat image = renderEnvCamera(world, camera, lookingDown({20, 10, 2.9}, 0.3, 0.05, 1.0),
                                        robot, RenderOptions{}, rng);
  ASSERT_EQ(image.type(), CV_8UC1);
  ASSERT_EQ(image.cols, 1920);
  ASSERT_EQ(image.rows, 1080);
  dump(image, "env_default_world");
  int black = 0, checked = 0;
  for (int v = 0; v < image.rows; v += 7) {
    for (int u = 0; u < image.cols; u += 7) {
      if (camera.unproject(Eigen::Vector2d(u, v))) continue;
      ++checked;
      black += image.at<std::uint8_t>(v, u) == 0;
    }
  }
  EXPECT_GT(checked, 0);  // this calibration's corners have no rays
  EXPECT_EQ(black, checked);
  // The floor in the middle is neither black nor saturated.
  const double centre = cv::mean(image(cv::Rect(900, 500, 120, 80)))[0];
  EXPECT_GT(centre, 40);
  EXPECT_LT(centre, 220);
}

// ---------------------------------------------------------------- fisheye

/// The fisheye on a robot at (x, y), 0.3 m above the floor, looking up.
Rigid3d fisheyeAt(double x, double y, double yaw) {
  return Rigid3d(rotZ(yaw), Eigen::Vector3d(x, y, 0.3));
}

/// Offsets [px] between the blobs a cv::SimpleBlobDetector (dark blobs)
/// finds and the projections of the housings' optical centres, for housings
/// overhead and at increasing angles from the zenith; checks that the pixels
/// around each projection are dark.
std::vector<double> housingBlobOffsets(double mount_radius, const char* name) {
  const Camera fisheye = fisheyeCamera();
  World world(WorldSpec{}, 5);
  const Rigid3d world_from_fisheye = fisheyeAt(18.3, 9.6, 0.4);
  const std::vector<Eigen::Vector2d> offsets = {{0.0, 0.0},   {0.9, 0.4}, {-1.5, 1.2}, {2.5, -1.0},
                                                {-3.0, -2.0}, {4.5, 1.5}, {-6.5, -2.0}};
  std::vector<Eigen::Vector3d> centres;
  for (const Eigen::Vector2d& o : offsets) {
    const double x = world_from_fisheye.translation.x() + o.x(),
                 y = world_from_fisheye.translation.y() + o.y();
    // A dome camera hanging 12 cm below the ceiling on its post.
    const Eigen::Vector3d centre(x, y, world.ceilingHeightAt(x, y) - 0.12);
    world.addHousing({"cam", centre, 0.06, 0.12, mount_radius});
    centres.push_back(centre);
  }
  std::mt19937 rng(8);
  const auto start = std::chrono::steady_clock::now();
  const cv::Mat image = renderFisheye(world, fisheye, world_from_fisheye, RenderOptions{}, rng);
  std::printf("%s: fisheye frame rendered in %.2f s\n", name, seconds(start));
  dump(image, std::string("fisheye_housings_") + name);

  cv::SimpleBlobDetector::Params params;
  params.filterByColor = true;
  params.blobColor = 0;
  params.minThreshold = 10;
  params.maxThreshold = 120;
  params.thresholdStep = 10;
  params.filterByArea = true;
  params.minArea = 15;
  params.maxArea = 20000;
  params.filterByCircularity = true;
  params.minCircularity = 0.6f;
  params.filterByConvexity = true;
  params.minConvexity = 0.85f;
  params.filterByInertia = true;
  params.minInertiaRatio = 0.3f;
  std::vector<cv::KeyPoint> blobs;
  cv::SimpleBlobDetector::create(params)->detect(image, blobs);

  const Rigid3d fisheye_from_world = world_from_fisheye.inverse();
  std::vector<double> out;
  for (std::size_t k = 0; k < centres.size(); ++k) {
    const Eigen::Vector3d in_camera = fisheye_from_world * centres[k];
    const std::optional<Eigen::Vector2d> px = fisheye.project(in_camera);
    EXPECT_TRUE(px && fisheye.isInImage(*px, 10.0)) << k;
    if (!px || !fisheye.isInImage(*px, 10.0)) continue;
    // The pixels around the projection are the dark housing.
    const cv::Rect around(static_cast<int>(std::lround(px->x())) - 2,
                          static_cast<int>(std::lround(px->y())) - 2, 5, 5);
    const double dark = cv::mean(image(around))[0];
    EXPECT_LT(dark, 40.0) << "housing " << k;
    double nearest = 1e9, size = 0.0;
    for (const cv::KeyPoint& b : blobs) {
      const double d = std::hypot(b.pt.x - px->x(), b.pt.y - px->y());
      if (d < nearest) {
        nearest = d;
        size = b.size;
      }
    }
    std::printf(
        "  housing %zu at %.1f deg from the axis: mean grey %.1f around the projection, blob %.2f "
        "px away "
        "(diameter %.1f px)\n",
        k, std::acos(in_camera.normalized().z()) / kDeg, dark, nearest, size);
    out.push_back(nearest);
  }
  return out;
}

TEST(RenderFisheye, HousingsAppearWhereTheGroundTruthProjects) {
  // The dome is a sphere about the optical centre, so its blob is centred on
  // the projection; the thin mount post above it drags the blob centroid
  // towards the ceiling when seen obliquely.
  const std::vector<double> with_post = housingBlobOffsets(0.02, "dome_and_post");
  const std::vector<double> dome_only = housingBlobOffsets(0.0, "dome_only");
  ASSERT_EQ(with_post.size(), 7u);
  ASSERT_EQ(dome_only.size(), 7u);
  // Observed: <= 1.3 px with the post (up to 63 deg off axis), <= 0.1 px
  // for the dome alone.
  EXPECT_LE(*std::max_element(with_post.begin(), with_post.end()), 2.0);
  EXPECT_LE(*std::max_element(dome_only.begin(), dome_only.end()), 0.3);
}

/// FAST corners (threshold 20 grey levels: far above the noise) inside the
/// image circle, within `max_angle` of the optical axis.
int countCorners(const cv::Mat& image, const Camera& camera, double max_angle) {
  std::vector<cv::KeyPoint> corners;
  cv::FAST(image, corners, 20, true);
  int inside = 0;
  for (const cv::KeyPoint& k : corners) {
    const auto b = camera.unproject(Eigen::Vector2d(k.pt.x, k.pt.y));
    if (b && b->z() > std::cos(max_angle) &&
        image.at<std::uint8_t>(cvRound(k.pt.y), cvRound(k.pt.x)) > 0)
      ++inside;
  }
  return inside;
}

TEST(RenderFisheye, TexturedExceptInTheLowTextureRegion) {
  const Camera fisheye = fisheyeCamera();
  WorldSpec spec;
  spec.low_texture_region = {4.0, 0.0, 16.0, 20.0};
  const World world(spec, 31);
  std::mt19937 rng(4);
  int least = 1 << 30;
  for (const Eigen::Vector2d& at :
       {Eigen::Vector2d(24.0, 6.0), Eigen::Vector2d(31.0, 12.5), Eigen::Vector2d(37.0, 17.0)}) {
    const cv::Mat image =
        renderFisheye(world, fisheye, fisheyeAt(at.x(), at.y(), 1.0), RenderOptions{}, rng);
    const int all = countCorners(image, fisheye, 95 * kDeg);
    const int central = countCorners(image, fisheye, 50 * kDeg);
    std::printf("textured ceiling at (%.0f, %.0f): %d corners, %d within 50 deg of the axis\n",
                at.x(), at.y(), all, central);
    dump(image, "fisheye_textured_" + std::to_string(static_cast<int>(at.x())));
    least = std::min(least, all);
    EXPECT_GT(central, 100);
  }
  EXPECT_GT(least, 200);
  const cv::Mat plain =
      renderFisheye(world, fisheye, fisheyeAt(10.0, 10.0, 1.0), RenderOptions{}, rng);
  dump(plain, "fisheye_low_texture");
  const int central = countCorners(plain, fisheye, 50 * kDeg);
  std::printf("low-texture region: %d corners within 50 deg of the axis\n", central);
  EXPECT_LT(central, 25);
}

TEST(Render, DeterministicForTheSameSeed) {
  const Camera fisheye = fisheyeCamera();
  World world(WorldSpec{}, 12);
  world.addHousing({"a", {21.0, 9.0, 2.8}, 0.06, 0.1, 0.02});
  std::mt19937 rng_a(77), rng_b(77), rng_c(78);
  const Rigid3d pose = fisheyeAt(20.0, 10.0, 0.2);
  const cv::Mat a = renderFisheye(world, fisheye, pose, RenderOptions{}, rng_a);
  const cv::Mat b = renderFisheye(world, fisheye, pose, RenderOptions{}, rng_b);
  const cv::Mat c = renderFisheye(world, fisheye, pose, RenderOptions{}, rng_c);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1), 0.0);  // other noise
  {
    // Whatever the number of threads.
    const int threads = cv::getNumThreads();
    cv::setNumThreads(1);
    std::mt19937 rng_single(77);
    const cv::Mat single = renderFisheye(world, fisheye, pose, RenderOptions{}, rng_single);
    cv::setNumThreads(threads);
    EXPECT_EQ(cv::norm(a, single, cv::NORM_INF), 0.0);
  }
  // Advancing the generator changes the next frame's noise, not the scene.
  const cv::Mat a2 = renderFisheye(world, fisheye, pose, RenderOptions{}, rng_a);
  EXPECT_GT(cv::norm(a, a2, cv::NORM_L1), 0.0);
  EXPECT_LT(cv::norm(a, a2, cv::NORM_L1) / (a.rows * a.cols), 4.0);

  const Camera camera = envCamera();
  RobotAppearance robot;
  robot.world_from_base = Rigid3d(rotZ(0.7), Eigen::Vector3d(20.2, 10.1, 0.0));
  robot.world_from_marker = Rigid3d(rotZ(0.7), Eigen::Vector3d(20.2, 10.1, 0.25));
  RenderOptions options;
  options.motion_blur_px = 3.5;
  options.exposure = 0.8;
  std::mt19937 rng_d(5), rng_e(5);
  const Rigid3d down = lookingDown({20, 10, 2.9}, 0.1, 0.03, 0.0);
  const cv::Mat d = renderEnvCamera(world, camera, down, robot, options, rng_d);
  const cv::Mat e = renderEnvCamera(world, camera, down, robot, options, rng_e);
  EXPECT_EQ(cv::norm(d, e, cv::NORM_INF), 0.0);
  // No noise: two different generators give the same frame.
  options.noise_sigma = 0.0;
  const cv::Mat f = renderEnvCamera(world, camera, down, robot, options, rng_d);
  const cv::Mat g = renderEnvCamera(world, camera, down, robot, options, rng_c);
  EXPECT_EQ(cv::norm(f, g, cv::NORM_INF), 0.0);
}

TEST(RenderEnvCamera, FramesFromABackgroundAreTheFramesRenderedWhole) {
  // A full recording's frames come from the camera's static view with only
  // the robot's box cast again: the same frames wherever the robot is (in
  // view, across the image's edge, away), at the background's exposure. At
  // another exposure the adaptive supersampling decides some pixels the
  // other way: a few hundred of two million differ by more than 2 grey
  // levels (a fine feature the pixel's corners miss), 0.02 on average.
  const Camera camera = envCamera();
  World world(WorldSpec{}, 12);
  const Rigid3d down = lookingDown({20, 10, 2.9}, 0.1, 0.03, 0.0);
  RenderOptions options;
  options.exposure = 0.9;
  const EnvBackground background = renderEnvBackground(world, camera, down, options);
  // Where the marker's centre is 20 px inside the image's right edge: the
  // robot's body crosses it.
  double edge_x = 20.0;
  for (; edge_x < 30.0; edge_x += 0.01) {
    const auto px = camera.project(down.inverse() * Eigen::Vector3d(edge_x, 10.1, 0.25));
    if (!px || px->x() > camera.width() - 20) break;
  }
  ASSERT_LT(edge_x, 30.0);
  for (const Eigen::Vector3d& at :
       {Eigen::Vector3d(20.2, 10.1, 0), Eigen::Vector3d(edge_x, 10.1, 0),
        Eigen::Vector3d(30.0, 3.0, 0)}) {
    RobotAppearance robot;
    robot.world_from_base = Rigid3d(rotZ(0.7), at);
    robot.world_from_marker = Rigid3d(rotZ(0.7), at + Eigen::Vector3d(0, 0, 0.25));
    std::mt19937 rng_whole(9), rng_reused(9), rng_empty(9);
    const cv::Mat whole = renderEnvCamera(world, camera, down, robot, options, rng_whole);
    const cv::Mat reused =
        renderEnvCamera(world, camera, down, robot, options, rng_reused, &background);
    EXPECT_EQ(cv::norm(whole, reused, cv::NORM_INF), 0.0) << at.transpose();
    // The robot is in the first two frames (not in the third).
    RobotAppearance away = robot;
    away.world_from_base.translation += Eigen::Vector3d(100, 0, 0);
    away.world_from_marker.translation += Eigen::Vector3d(100, 0, 0);
    const cv::Mat empty = renderEnvCamera(world, camera, down, away, options, rng_empty);
    EXPECT_EQ(cv::norm(whole, empty, cv::NORM_INF) > 100, at.x() < 30) << at.transpose();
    RenderOptions brighter = options;
    brighter.exposure = 1.1;
    std::mt19937 rng_a(9), rng_b(9);
    const cv::Mat a = renderEnvCamera(world, camera, down, robot, brighter, rng_a);
    const cv::Mat b = renderEnvCamera(world, camera, down, robot, brighter, rng_b, &background);
    cv::Mat differ;
    cv::absdiff(a, b, differ);
    EXPECT_LT(cv::countNonZero(differ > 2), 500) << at.transpose();
    EXPECT_LT(cv::norm(a, b, cv::NORM_L1) / (a.rows * a.cols), 0.03) << at.transpose();
  }
}

}  // namespace
}  // namespace lookboth::sim
