#include "lookboth/detect/blob_detector.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>

#include "lookboth/core/error.h"

namespace lookboth {
namespace {

// About the 1920x1080 fisheye's scale (r = f theta: 90 deg at 628 px).
constexpr int kWidth = 1280, kHeight = 960;
constexpr double kFocal = 400;

/// An upward equidistant fisheye (Kannala-Brandt, no distortion).
Camera fisheye() {
  return Camera(KannalaBrandtModel{}, kWidth, kHeight,
                {kFocal, kFocal, 0.5 * (kWidth - 1), 0.5 * (kHeight - 1), 0, 0, 0, 0});
}

/// The diameter [px] of a sphere of `radius` [m] on the ray of pixel (u, v),
/// `height` [m] above the fisheye: the points a radius from its centre,
/// across the ray, along and across the image radius give its image's two
/// axes; the diameter of the circle of the same area.
double sphereDiameter(const Camera& camera, double u, double v, double radius, double height) {
  const Eigen::Vector3d ray = *camera.unproject({u, v});
  const Eigen::Vector3d centre = (height / ray.z()) * ray;
  Eigen::Vector3d across = ray.cross(Eigen::Vector3d::UnitZ());
  if (across.norm() < 1e-9) across = Eigen::Vector3d::UnitX();
  across.normalize();
  const Eigen::Vector3d along = ray.cross(across).normalized();
  const double a =
      (*camera.project(centre + radius * across) - *camera.project(centre - radius * across))
          .norm();
  const double b =
      (*camera.project(centre + radius * along) - *camera.project(centre - radius * along)).norm();
  return std::sqrt(a * b);
}

/// A ceiling of grey `background` with dark discs (antialiased, sub-pixel).
struct Disc {
  double u, v, diameter;
  int grey;
};

cv::Mat frame(int background, const std::vector<Disc>& discs) {
  cv::Mat grey(kHeight, kWidth, CV_8UC1, cv::Scalar(background));
  constexpr int kShift = 4;
  for (const Disc& d : discs) {
    cv::circle(grey, cv::Point(std::lround(d.u * 16), std::lround(d.v * 16)),
               static_cast<int>(std::lround(0.5 * d.diameter * 16)), cv::Scalar(d.grey), cv::FILLED,
               cv::LINE_AA, kShift);
  }
  return grey;
}

/// The blob nearest (u, v) within `radius` px, if any.
const Blob* near(const std::vector<Blob>& blobs, double u, double v, double radius = 2.0) {
  const Blob* best = nullptr;
  for (const Blob& b : blobs) {
    const double d = std::hypot(b.u - u, b.v - v);
    if (d < radius && (!best || d < std::hypot(best->u - u, best->v - v))) best = &b;
  }
  return best;
}

TEST(BlobDetectorTest, HousingDiameterRangeIsTheSphereSeenFromTheHeights) {
  const Camera camera = fisheye();
  BlobDetectorOptions options;
  options.housing_radius_m = 0.06;
  options.min_housing_height_m = 2.0;
  options.max_housing_height_m = 6.0;
  const BlobDetector detector(options, &camera);
  // Straight up, an equidistant fisheye sees the sphere's rim at
  // theta = atan(R / h): diameter 2 f atan(R / h).
  const auto centre = detector.housingDiameterRange(0.5 * (kWidth - 1), 0.5 * (kHeight - 1));
  ASSERT_TRUE(centre);
  EXPECT_NEAR(centre->first, 2 * kFocal * std::atan(0.06 / 6.0), 1e-6);
  EXPECT_NEAR(centre->second, 2 * kFocal * std::atan(0.06 / 2.0), 1e-6);
  // Off axis the housing is further along its ray and squeezed along the
  // image radius: smaller than straight up.
  const double u = 0.5 * (kWidth - 1) + 450, v = 0.5 * (kHeight - 1);
  const auto side = detector.housingDiameterRange(u, v);
  ASSERT_TRUE(side);
  EXPECT_LT(side->second, 0.7 * centre->second);
  EXPECT_NEAR(side->first, sphereDiameter(camera, u, v, 0.06, 6.0), 1e-6);
  EXPECT_NEAR(side->second, sphereDiameter(camera, u, v, 0.06, 2.0), 1e-6);
  // Without a calibration there is no range.
  EXPECT_FALSE(BlobDetector(options).housingDiameterRange(320, 240));
}

// A tie hole or sprinkler head (a third of a housing's size) and a missing
// tile (three times it), as dark as a housing, are not housings; a blob of
// a housing's size at its place is.
TEST(BlobDetectorTest, KeepsOnlyBlobsOfAHousingsSizeForTheirPlace) {
  const Camera camera = fisheye();
  const double u0 = 0.5 * (kWidth - 1), v0 = 0.5 * (kHeight - 1);
  // At the paper's ceiling, 3-3.5 m above the fisheye.
  const Disc housing{u0 + 40.3, v0 - 20.6, sphereDiameter(camera, u0 + 40.3, v0 - 20.6, 0.06, 3.0),
                     10};
  const Disc tie_hole{u0 - 60.2, v0 + 30.7,
                      sphereDiameter(camera, u0 - 60.2, v0 + 30.7, 0.018, 3.5), 10};
  const Disc tile{u0 + 10.4, v0 + 90.1, 3 * sphereDiameter(camera, u0 + 10.4, v0 + 90.1, 0.06, 2.0),
                  10};
  ASSERT_GT(tie_hole.diameter, 3.0);  // big enough for min_area_px
  const cv::Mat grey = frame(150, {housing, tie_hole, tile});

  BlobDetectorOptions options;
  const std::vector<Blob> blobs = BlobDetector(options, &camera).detect(grey);
  std::string found;
  for (const Blob& b : blobs) {
    found += " (" + std::to_string(b.u) + ", " + std::to_string(b.v) + ") " +
             std::to_string(b.diameter_px) + " px";
  }
  ASSERT_EQ(blobs.size(), 1u) << "blobs:" << found;
  ASSERT_TRUE(near(blobs, housing.u, housing.v, 0.5));
  EXPECT_NEAR(blobs[0].diameter_px, housing.diameter, 0.2 * housing.diameter);

  // The size test is what drops the other two: without it (or without the
  // calibration it needs) all three are blobs.
  options.housing_size_tolerance = 0;
  EXPECT_EQ(BlobDetector(options, &camera).detect(grey).size(), 3u);
  EXPECT_EQ(BlobDetector(BlobDetectorOptions{}).detect(grey).size(), 3u);
}

// A grey disc with the contrast the contrast test asks for is no housing
// unless it is near-black against the ceiling; the ratio does not depend on
// the exposure.
TEST(BlobDetectorTest, KeepsOnlyBlobsFarDarkerThanTheCeilingAroundThem) {
  const Camera camera = fisheye();
  const double u0 = 0.5 * (kWidth - 1), v0 = 0.5 * (kHeight - 1);
  const double d1 = sphereDiameter(camera, u0 - 50, v0, 0.06, 3.0);
  const double d2 = sphereDiameter(camera, u0 + 50, v0, 0.06, 3.0);
  for (const double exposure : {1.0, 0.6}) {
    const auto level = [&](int grey) { return static_cast<int>(std::lround(grey * exposure)); };
    // Ceiling 150: a housing at 12 (ratio 0.08), a dark grey patch at 40
    // (0.27, contrast 110: the contrast test alone keeps it).
    const cv::Mat grey =
        frame(level(150), {{u0 - 50, v0, d1, level(12)}, {u0 + 50, v0, d2, level(40)}});
    BlobDetectorOptions options;
    std::vector<Blob> blobs = BlobDetector(options, &camera).detect(grey);
    ASSERT_EQ(blobs.size(), 1u) << "exposure " << exposure;
    EXPECT_TRUE(near(blobs, u0 - 50, v0, 0.5));
    options.max_darkness_ratio = 1;
    EXPECT_EQ(BlobDetector(options, &camera).detect(grey).size(), 2u) << "exposure " << exposure;
  }
}

// A housing in front of a darker surface than the ceiling (a cable tray's
// bay) merges with it at the thresholds above the surface's grey. With the
// dark, fine thresholds most of the housing's levels are its own and the
// blob has its size; with 10-100 by 10 most are the merged blob's, too big
// for a housing.
TEST(BlobDetectorTest, FindsAHousingInFrontOfADarkBay) {
  const Camera camera = fisheye();
  const double u = 0.5 * (kWidth - 1) + 70.4, v = 0.5 * (kHeight - 1) - 35.2;
  const double diameter = sphereDiameter(camera, u, v, 0.06, 3.0);
  cv::Mat grey = frame(150, {});
  const double side = 3.2 * diameter;
  cv::rectangle(grey, cv::Point2d(u - side / 2, v - side / 2),
                cv::Point2d(u + side / 2, v + side / 2), cv::Scalar(45), cv::FILLED);
  constexpr int kShift = 4;
  cv::circle(grey, cv::Point(std::lround(u * 16), std::lround(v * 16)),
             static_cast<int>(std::lround(0.5 * diameter * 16)), cv::Scalar(6), cv::FILLED,
             cv::LINE_AA, kShift);
  BlobDetectorOptions options;
  const std::vector<Blob> blobs = BlobDetector(options, &camera).detect(grey);
  ASSERT_EQ(blobs.size(), 1u);
  const Blob* housing = near(blobs, u, v, 0.5);
  ASSERT_TRUE(housing);
  EXPECT_NEAR(housing->diameter_px, diameter, 0.25 * diameter);

  options.max_threshold = 110;
  options.threshold_step = 10;
  BlobDetectorStats stats;
  EXPECT_TRUE(BlobDetector(options, &camera).detect(grey, &stats).empty());
  EXPECT_EQ(stats.too_big, 1);
}

TEST(BlobDetectorTest, ChecksTheHousingOptions) {
  EXPECT_EQ(BlobDetectorOptions{}.check(), "");
  BlobDetectorOptions o;
  o.max_darkness_ratio = 0;
  EXPECT_NE(o.check().find("max_darkness_ratio"), std::string::npos);
  o = {};
  o.housing_radius_m = -0.06;
  EXPECT_NE(o.check().find("housing_radius_m"), std::string::npos);
  o = {};
  o.min_housing_height_m = 7;
  EXPECT_NE(o.check().find("min_housing_height_m"), std::string::npos);
  o = {};
  o.housing_size_tolerance = 0.5;
  EXPECT_NE(o.check().find("housing_size_tolerance"), std::string::npos);
  o.housing_size_tolerance = 0;
  EXPECT_EQ(o.check(), "");
  o.max_darkness_ratio = 2;
  EXPECT_THROW(BlobDetector{o}, Error);
}

}  // namespace
}  // namespace lookboth
