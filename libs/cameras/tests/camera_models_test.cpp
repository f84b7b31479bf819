// Camera models: round trips over the whole valid field of view with random
// realistic parameters, invalid inputs, fisheye coverage, agreement with
// OpenCV and exactness of the automatic derivatives.
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "lookboth/cameras/camera.h"

namespace lookboth {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

Eigen::Vector3d rayAt(double incidence, double azimuth) {
  return {std::sin(incidence) * std::cos(azimuth), std::sin(incidence) * std::sin(azimuth),
          std::cos(incidence)};
}

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

/// OCamCalib-style parameters of a lens whose sensor radius is
/// rho = f theta (1 + kappa theta^2): the direct polynomial (a1 = 0, degree 4)
/// fitted over rho in [0, rho_max], and an inverse polynomial with `num_inv`
/// coefficients fitted to the direct one, as OCamCalib does.
std::vector<double> scaramuzzaParams(double cx, double cy, double c, double d, double e, double f,
                                     double kappa, double rho_max, int num_inv) {
  const auto lens_rho = [&](double theta) { return f * theta * (1.0 + kappa * theta * theta); };
  double theta_max = rho_max / f;  // solve lens_rho(theta_max) = rho_max
  for (int i = 0; i < 100; ++i) {
    const double derivative = f * (1.0 + 3.0 * kappa * theta_max * theta_max);
    theta_max -= (lens_rho(theta_max) - rho_max) / derivative;
  }
  constexpr int kSamples = 400;
  Eigen::MatrixXd design(kSamples + 1, 4);
  Eigen::VectorXd target(kSamples + 1);
  for (int i = 0; i <= kSamples; ++i) {
    const double theta = theta_max * i / kSamples;
    const double rho = lens_rho(theta);
    const double s = rho / rho_max;
    design.row(i) << 1.0, s * s, s * s * s, s * s * s * s;
    // z_o = poly(rho) = -rho / tan(theta); the limit on the axis is -f.
    target(i) = theta == 0.0 ? -f : -rho * std::cos(theta) / std::sin(theta);
  }
  const Eigen::VectorXd b = design.colPivHouseholderQr().solve(target);
  const std::vector<double> a = {b(0), 0.0, b(1) / (rho_max * rho_max), b(2) / std::pow(rho_max, 3),
                                 b(3) / std::pow(rho_max, 4)};
  std::vector<double> params = {cx, cy, c, d, e};
  params.insert(params.end(), a.begin(), a.end());
  if (num_inv > 0) {
    Eigen::MatrixXd inv_design(kSamples, num_inv);
    Eigen::VectorXd inv_target(kSamples);
    for (int i = 0; i < kSamples; ++i) {
      const double rho = rho_max * (i + 1) / kSamples;
      double poly = 0.0;
      for (int k = 4; k >= 0; --k) poly = poly * rho + a[static_cast<std::size_t>(k)];
      const double theta_o = std::atan(poly / rho);
      for (int k = 0; k < num_inv; ++k) inv_design(i, k) = std::pow(theta_o, k);
      inv_target(i) = rho;
    }
    const Eigen::VectorXd inv = inv_design.colPivHouseholderQr().solve(inv_target);
    for (int k = 0; k < num_inv; ++k) params.push_back(inv(k));
  }
  return params;
}

struct ImageSize {
  int width;
  int height;
};

const std::vector<CameraModelId> kAllModels = {
    CameraModelId::kPinhole,       CameraModelId::kRadTan,     CameraModelId::kRationalPolynomial,
    CameraModelId::kKannalaBrandt, CameraModelId::kScaramuzza, CameraModelId::kDoubleSphere,
    CameraModelId::kEucm,          CameraModelId::kMei,        CameraModelId::kFov};

/// A camera of the given model with random parameters in realistic ranges.
Camera randomCamera(CameraModelId id, std::mt19937& rng) {
  const std::vector<ImageSize> sizes = {{640, 480}, {1280, 720}, {1280, 1024}, {1920, 1080}};
  const ImageSize size = sizes[std::uniform_int_distribution<std::size_t>(0, 3)(rng)];
  const double w = size.width, h = size.height;
  const double cx = 0.5 * (w - 1.0) + uniform(rng, -0.03, 0.03) * w;
  const double cy = 0.5 * (h - 1.0) + uniform(rng, -0.03, 0.03) * h;
  const double aspect = uniform(rng, 0.98, 1.02);
  const double scale = w / 1920.0;  // focal lengths below are for a 1920 px wide image
  switch (id) {
    case CameraModelId::kPinhole: {
      const double f = uniform(rng, 0.4, 1.2) * w;
      return Camera(PinholeModel{}, size.width, size.height, {f, f * aspect, cx, cy});
    }
    case CameraModelId::kRadTan: {
      const double f = uniform(rng, 0.4, 1.2) * w;
      return Camera(
          RadTanModel{}, size.width, size.height,
          {f, f * aspect, cx, cy, uniform(rng, -0.35, 0.25), uniform(rng, -0.15, 0.2),
           uniform(rng, -2e-3, 2e-3), uniform(rng, -2e-3, 2e-3), uniform(rng, -0.05, 0.05)});
    }
    case CameraModelId::kRationalPolynomial: {
      const double f = uniform(rng, 0.4, 1.2) * w;
      const double k1 = uniform(rng, -0.3, 3.0), k2 = uniform(rng, -0.1, 1.0);
      return Camera(
          RationalPolynomialModel{}, size.width, size.height,
          {f, f * aspect, cx, cy, k1, k2, uniform(rng, -2e-3, 2e-3), uniform(rng, -2e-3, 2e-3),
           uniform(rng, -0.01, 0.05), k1 + uniform(rng, -0.1, 0.6), k2 + uniform(rng, -0.1, 0.5),
           uniform(rng, 0.0, 0.1)});
    }
    case CameraModelId::kKannalaBrandt: {
      const double f = uniform(rng, 250.0, 700.0) * scale;
      return Camera(KannalaBrandtModel{}, size.width, size.height,
                    {f, f * aspect, cx, cy, uniform(rng, -0.05, 0.05), uniform(rng, -0.02, 0.02),
                     uniform(rng, -5e-3, 5e-3), uniform(rng, -1e-3, 1e-3)});
    }
    case CameraModelId::kScaramuzza: {
      const double corner = std::hypot(0.5 * w, 0.5 * h);
      const double f = corner / uniform(rng, 1.2, 1.9);
      const int num_inv = std::uniform_int_distribution<int>(0, 1)(rng) == 0 ? 0 : 10;
      const std::vector<double> params = scaramuzzaParams(
          cx, cy, 1.0 + uniform(rng, -1e-3, 1e-3), uniform(rng, -1e-3, 1e-3),
          uniform(rng, -1e-3, 1e-3), f, uniform(rng, -0.03, 0.03), 1.05 * corner, num_inv);
      return Camera(ScaramuzzaModel{5, num_inv}, size.width, size.height, params);
    }
    case CameraModelId::kDoubleSphere: {
      const double xi = uniform(rng, -0.3, 0.7);
      const double f = uniform(rng, 250.0, 700.0) * scale * (1.0 + xi);
      return Camera(DoubleSphereModel{}, size.width, size.height,
                    {f, f * aspect, cx, cy, xi, uniform(rng, 0.3, 0.7)});
    }
    case CameraModelId::kEucm: {
      const double f = uniform(rng, 250.0, 700.0) * scale;
      return Camera(EucmModel{}, size.width, size.height,
                    {f, f * aspect, cx, cy, uniform(rng, 0.35, 0.7), uniform(rng, 0.8, 1.3)});
    }
    case CameraModelId::kMei: {
      const double xi = uniform(rng, 0.3, 2.0);
      const double f = uniform(rng, 250.0, 700.0) * scale * (1.0 + xi);
      return Camera(MeiModel{}, size.width, size.height,
                    {f, f * aspect, cx, cy, xi, uniform(rng, -0.2, 0.1), uniform(rng, -0.02, 0.05),
                     uniform(rng, -1e-3, 1e-3), uniform(rng, -1e-3, 1e-3)});
    }
    case CameraModelId::kFov: {
      const double fov_w = uniform(rng, 0.6, 1.1);
      const double f = uniform(rng, 0.35, 1.0) * w;
      return Camera(FovModel{}, size.width, size.height, {f, f * aspect, cx, cy, fov_w});
    }
  }
  throw std::logic_error("unknown model");
}

std::string describe(const Camera& camera) {
  std::ostringstream text;
  text.precision(17);
  text << camera.description() << ", params:";
  for (double p : camera.params()) text << " " << p;
  return text.str();
}

/// A scale for each parameter: the size of a change that matters, for finite
/// differences and for comparing derivatives.
std::vector<double> paramScales(const Camera& camera) {
  const std::vector<double>& params = camera.params();
  std::vector<double> scales(params.size());
  for (std::size_t i = 0; i < params.size(); ++i) scales[i] = std::max(std::abs(params[i]), 0.1);
  if (const auto* model = std::get_if<ScaramuzzaModel>(&camera.model())) {
    const double a0 = std::abs(params[5]);
    for (int i = 0; i < model->num_poly; ++i) {
      scales[static_cast<std::size_t>(5 + i)] = std::pow(a0, 1.0 - i);  // a_i rho^i ~ a0
    }
  }
  return scales;
}

class CameraModelsRoundTrip : public testing::TestWithParam<CameraModelId> {};

std::string modelParamName(const testing::TestParamInfo<CameraModelId>& info) {
  const char* names[] = {"Pinhole",       "RadTan",     "RationalPolynomial",
                         "KannalaBrandt", "Scaramuzza", "DoubleSphere",
                         "Eucm",          "Mei",        "Fov"};
  return names[static_cast<int>(info.param)];
}

INSTANTIATE_TEST_SUITE_P(AllModels, CameraModelsRoundTrip, testing::ValuesIn(kAllModels),
                         modelParamName);

TEST_P(CameraModelsRoundTrip, RayToPixelToRayOverTheWholeValidFieldOfView) {
  std::mt19937 rng(1000 + static_cast<unsigned>(GetParam()));
  for (int trial = 0; trial < 10; ++trial) {
    const Camera camera = randomCamera(GetParam(), rng);
    SCOPED_TRACE(describe(camera));
    const double max_angle = camera.maxIncidenceAngle();
    ASSERT_GT(max_angle, 10.0 * kDeg);
    double worst = 0.0;
    for (int i = 0; i < 2000; ++i) {
      const Eigen::Vector3d point =
          rayAt(uniform(rng, 0.0, max_angle), uniform(rng, 0.0, 2.0 * kPi)) *
          uniform(rng, 0.1, 100.0);
      const auto pixel = camera.project(point);
      ASSERT_TRUE(pixel) << "point " << point.transpose();
      const auto bearing = camera.unproject(*pixel);
      ASSERT_TRUE(bearing) << "point " << point.transpose() << " pixel " << pixel->transpose();
      EXPECT_NEAR(bearing->norm(), 1.0, 1e-12);
      worst = std::max(worst, angleBetween(*bearing, point));
    }
    EXPECT_LT(worst, 1e-9);
  }
}

TEST_P(CameraModelsRoundTrip, PixelToRayToPixelOverTheImage) {
  std::mt19937 rng(2000 + static_cast<unsigned>(GetParam()));
  for (int trial = 0; trial < 10; ++trial) {
    const Camera camera = randomCamera(GetParam(), rng);
    SCOPED_TRACE(describe(camera));
    int valid = 0;
    double worst = 0.0;
    for (int i = 0; i < 2000; ++i) {
      const Eigen::Vector2d pixel(uniform(rng, -0.5, camera.width() - 0.5),
                                  uniform(rng, -0.5, camera.height() - 0.5));
      const auto bearing = camera.unproject(pixel);
      if (!bearing) continue;
      ++valid;
      const auto back = camera.project(*bearing);
      ASSERT_TRUE(back) << "pixel " << pixel.transpose() << " bearing " << bearing->transpose();
      worst = std::max(worst, (*back - pixel).norm());
    }
    EXPECT_GT(valid, 100);  // 5% of the image: small fisheye circles leave most of it dark
    EXPECT_LT(worst, 1e-6);
  }
}

TEST(CameraModelsTest, PinholeTypesRejectPointsAtOrBehindTheImagePlane) {
  std::mt19937 rng(3);
  const std::vector<Eigen::Vector3d> points = {
      {0.0, 0.0, -1.0}, {1.0, 0.0, 0.0}, {0.2, -0.3, -1.0}, {0.0, 0.0, 0.0}, {1.0, 1.0, -1e-12}};
  for (CameraModelId id : {CameraModelId::kPinhole, CameraModelId::kRadTan,
                           CameraModelId::kRationalPolynomial, CameraModelId::kFov}) {
    const Camera camera = randomCamera(id, rng);
    SCOPED_TRACE(describe(camera));
    for (const Eigen::Vector3d& point : points) {
      EXPECT_FALSE(camera.project(point)) << point.transpose();
      Eigen::Vector2d pixel;
      const bool ok = std::visit(
          [&](const auto& m) {
            return m.project(camera.params().data(), point.data(), pixel.data());
          },
          camera.model());
      EXPECT_FALSE(ok) << "model-level project of " << point.transpose();
    }
    EXPECT_LT(camera.maxIncidenceAngle(), 0.5 * kPi);
  }
}

TEST(CameraModelsTest, FisheyesRejectPointsBeyondTheMaxIncidenceAngle) {
  std::mt19937 rng(4);
  int checked = 0;
  for (CameraModelId id :
       {CameraModelId::kKannalaBrandt, CameraModelId::kScaramuzza, CameraModelId::kDoubleSphere,
        CameraModelId::kEucm, CameraModelId::kMei}) {
    for (int trial = 0; trial < 10; ++trial) {
      const Camera camera = randomCamera(id, rng);
      SCOPED_TRACE(describe(camera));
      const double max_angle = camera.maxIncidenceAngle();
      if (max_angle > kPi - 0.02) continue;
      ++checked;
      for (int a = 0; a < 12; ++a) {
        const double azimuth = 2.0 * kPi * a / 12.0;
        EXPECT_FALSE(camera.project(rayAt(max_angle + 0.01, azimuth)));
        EXPECT_TRUE(camera.project(rayAt(max_angle - 0.01, azimuth)));
      }
    }
  }
  EXPECT_GT(checked, 10);
}

TEST(CameraModelsTest, DoubleSpherePixelOutsideTheValidCircleHasNoRay) {
  // alpha = 0.7: valid for |m|^2 <= 1 / (2 alpha - 1) = 2.5, a radius of
  // 1.58 f = 632 px.
  const Camera camera(DoubleSphereModel{}, 1920, 1080, {400, 400, 959.5, 539.5, -0.2, 0.7});
  const double params[] = {400, 400, 959.5, 539.5, -0.2, 0.7};
  for (double radius : {640.0, 700.0, 900.0}) {
    const Eigen::Vector2d pixel(959.5 + radius, 539.5);
    EXPECT_FALSE(camera.unproject(pixel)) << radius;
    double bearing[3];
    EXPECT_FALSE(DoubleSphereModel{}.unproject(params, pixel.data(), bearing)) << radius;
  }
  EXPECT_TRUE(camera.unproject(Eigen::Vector2d(959.5 + 600.0, 539.5)));
}

TEST(CameraModelsTest, ScaramuzzaPixelsBeyondAFoldOfThePolynomialHaveNoRay) {
  // -poly(rho) = 300 - rho^2 / 900 + 2e-9 rho^4: the ray angle
  // atan2(rho, -poly(rho)) peaks near rho = 480 px and then decreases, well
  // inside a 1920x1080 image; pixels farther out repeat angles seen before.
  for (int num_inv : {0, 6}) {
    std::vector<double> params = {959.5,  539.5, 1.0,         0.0, 0.0,
                                  -300.0, 0.0,   1.0 / 900.0, 0.0, -2e-9};
    if (num_inv > 0) {  // a rough inverse polynomial: equidistant, rho = 300 (theta_o + pi/2)
      const std::vector<double> inv = {300.0 * kPi / 2.0, 300.0, 0.0, 0.0, 0.0, 0.0};
      params.insert(params.end(), inv.begin(), inv.end());
    }
    const Camera camera(ScaramuzzaModel{5, num_inv}, 1920, 1080, params);
    SCOPED_TRACE(describe(camera));
    double fold_angle = 0.0;
    for (double rho = 0.0; rho < 1200.0; rho += 0.01) {
      const double poly = -300.0 + rho * rho / 900.0 - 2e-9 * std::pow(rho, 4);
      fold_angle = std::max(fold_angle, std::atan2(rho, -poly));
    }
    EXPECT_LE(camera.maxIncidenceAngle(), fold_angle);
    EXPECT_GT(camera.maxIncidenceAngle(), fold_angle - 1.0 * kDeg);
    for (double rho : {700.0, 800.0, 1000.0}) {
      EXPECT_FALSE(camera.unproject(Eigen::Vector2d(959.5 + rho, 539.5))) << rho;
    }
    std::mt19937 rng(9);
    int valid = 0;
    double worst = 0.0;
    for (int i = 0; i < 2000; ++i) {
      const Eigen::Vector2d pixel(uniform(rng, -0.5, 1919.5), uniform(rng, -0.5, 1079.5));
      const auto bearing = camera.unproject(pixel);
      if (!bearing) continue;
      ++valid;
      const auto back = camera.project(*bearing);
      ASSERT_TRUE(back) << pixel.transpose();
      worst = std::max(worst, (*back - pixel).norm());
    }
    EXPECT_GT(valid, 200);
    EXPECT_LT(valid, 1500);
    EXPECT_LT(worst, 1e-6);
  }
}

TEST(CameraModelsTest, RadTanWithAFoldInsideTheImageRoundTripsUpToItsLimit) {
  // Pincushion turning into a fold (k1 > 0, k3 < 0) at 55.2 degrees, inside
  // the image: near the limit the distorted point, where Newton's method
  // naturally starts, lies past the fold.
  const Camera camera(RadTanModel{}, 640, 480,
                      {265.17, 262.13, 300.73, 246.71, 0.1425, 0.0047, -8e-4, -3e-4, -0.032});
  SCOPED_TRACE(describe(camera));
  const double max_angle = camera.maxIncidenceAngle();
  EXPECT_LT(max_angle, 55.2 * kDeg);
  EXPECT_GT(max_angle, 54.0 * kDeg);
  EXPECT_FALSE(camera.unproject(Eigen::Vector2d(639.5, 479.5)));  // corner beyond the fold
  std::mt19937 rng(10);
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d ray =
        rayAt(uniform(rng, 0.9 * max_angle, max_angle), uniform(rng, 0.0, 2.0 * kPi));
    const auto pixel = camera.project(ray);
    ASSERT_TRUE(pixel);
    const auto bearing = camera.unproject(*pixel);
    ASSERT_TRUE(bearing) << "ray " << ray.transpose() << " pixel " << pixel->transpose();
    EXPECT_LT(angleBetween(*bearing, ray), 1e-9);
  }
}

TEST(CameraModelsTest, NonFiniteInputsGiveNoResult) {
  std::mt19937 rng(5);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (CameraModelId id : kAllModels) {
    const Camera camera = randomCamera(id, rng);
    EXPECT_FALSE(camera.project(Eigen::Vector3d(nan, 0.0, 1.0))) << describe(camera);
    EXPECT_FALSE(camera.unproject(Eigen::Vector2d(nan, 10.0))) << describe(camera);
    EXPECT_FALSE(camera.project(Eigen::Vector3d::Zero())) << describe(camera);
  }
}

TEST(CameraModelsTest, Realistic1920x1080FisheyesReach190DegreesAndRoundTripAt94Degrees) {
  const double corner = std::hypot(960.0, 540.0);
  const std::vector<Camera> cameras = {
      Camera(KannalaBrandtModel{}, 1920, 1080,
             {540, 540.5, 959.5, 539.5, 0.02, -0.003, 5e-4, -1e-4}),
      Camera(DoubleSphereModel{}, 1920, 1080, {477, 477.5, 959.5, 539.5, -0.2, 0.6}),
      Camera(ScaramuzzaModel{5, 10}, 1920, 1080,
             scaramuzzaParams(959.5, 539.5, 1.0002, 1e-4, -2e-4, 540.0, 0.0, 1.05 * corner, 10)),
      Camera(ScaramuzzaModel{5, 0}, 1920, 1080,
             scaramuzzaParams(959.5, 539.5, 1.0, 0.0, 0.0, 540.0, -0.01, 1.05 * corner, 0)),
  };
  for (const Camera& camera : cameras) {
    SCOPED_TRACE(describe(camera));
    EXPECT_GE(camera.maxIncidenceAngle(), 95.0 * kDeg);
    EXPECT_GE(camera.fieldOfView(), 190.0 * kDeg);
    for (int a = 0; a < 36; ++a) {
      const Eigen::Vector3d ray = rayAt(94.0 * kDeg, 2.0 * kPi * a / 36.0);
      const auto pixel = camera.project(ray);
      ASSERT_TRUE(pixel) << "azimuth " << 10 * a << " deg";
      const auto bearing = camera.unproject(*pixel);
      ASSERT_TRUE(bearing) << "azimuth " << 10 * a << " deg";
      EXPECT_LT(angleBetween(*bearing, ray), 1e-9);
      if (a == 0 || a == 18) {
        EXPECT_TRUE(camera.isInImage(*pixel)) << pixel->transpose();
      }
    }
  }
}

/// Random points in front of `camera` within its valid field of view (and
/// below `max_angle`), at random depths.
std::vector<cv::Point3d> randomPoints(const Camera& camera, double max_angle, int count,
                                      std::mt19937& rng) {
  std::vector<cv::Point3d> points;
  const double limit = std::min(max_angle, camera.maxIncidenceAngle());
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d p =
        rayAt(uniform(rng, 0.0, limit), uniform(rng, 0.0, 2.0 * kPi)) * uniform(rng, 0.5, 20.0);
    points.emplace_back(p.x(), p.y(), p.z());
  }
  return points;
}

void expectSameAsOpenCv(const Camera& camera, const std::vector<cv::Point3d>& points,
                        const std::vector<cv::Point2d>& expected) {
  ASSERT_EQ(points.size(), expected.size());
  double worst = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto pixel = camera.project(Eigen::Vector3d(points[i].x, points[i].y, points[i].z));
    ASSERT_TRUE(pixel);
    worst = std::max(worst, std::hypot(pixel->x() - expected[i].x, pixel->y() - expected[i].y));
  }
  EXPECT_LT(worst, 1e-6) << describe(camera);
}

cv::Matx33d cameraMatrix(const std::vector<double>& p) {
  return {p[0], 0.0, p[2], 0.0, p[1], p[3], 0.0, 0.0, 1.0};
}

TEST(CameraModelsTest, RadTanAndRationalPolynomialMatchCvProjectPoints) {
  std::mt19937 rng(6);
  for (CameraModelId id : {CameraModelId::kRadTan, CameraModelId::kRationalPolynomial}) {
    for (int trial = 0; trial < 10; ++trial) {
      const Camera camera = randomCamera(id, rng);
      const std::vector<double>& p = camera.params();
      const std::vector<double> distortion(p.begin() + 4, p.end());  // 5 or 8 coefficients
      const std::vector<cv::Point3d> points = randomPoints(camera, kPi, 1000, rng);
      std::vector<cv::Point2d> expected;
      cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cameraMatrix(p), distortion,
                        expected);
      expectSameAsOpenCv(camera, points, expected);
    }
  }
}

TEST(CameraModelsTest, KannalaBrandtMatchesCvFisheyeProjectPointsInFront) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 10; ++trial) {
    const Camera camera = randomCamera(CameraModelId::kKannalaBrandt, rng);
    const std::vector<double>& p = camera.params();
    const std::vector<cv::Point3d> points = randomPoints(camera, 89.0 * kDeg, 1000, rng);
    std::vector<cv::Point2d> expected;
    cv::fisheye::projectPoints(points, expected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                               cameraMatrix(p), cv::Vec4d(p[4], p[5], p[6], p[7]));
    expectSameAsOpenCv(camera, points, expected);
  }
}

TEST(CameraModelsTest, MeiMatchesCvOmnidirProjectPoints) {
  // OpenCV's omnidir module (Mei's model, skew 0): the same pixels over the
  // whole valid field of view, so that a calibration from cv::omnidir or
  // Kalibr's omni-radtan means the same camera here.
  std::mt19937 rng(9);
  for (int trial = 0; trial < 10; ++trial) {
    const Camera camera = randomCamera(CameraModelId::kMei, rng);
    const std::vector<double>& p = camera.params();
    const std::vector<cv::Point3d> points = randomPoints(camera, kPi, 1000, rng);
    std::vector<cv::Point2d> expected;
    cv::omnidir::projectPoints(points, expected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                               cameraMatrix(p), p[4], cv::Vec4d(p[5], p[6], p[7], p[8]));
    expectSameAsOpenCv(camera, points, expected);
  }
}

TEST(CameraModelsTest, EucmWithBetaOneIsMeiWithoutDistortion) {
  // The extended model with beta = 1 is the unified one: xi = alpha / (1 - alpha),
  // f_mei = f_eucm / (1 - alpha).
  const double alpha = 0.6, f = 400.0;
  const Camera eucm(EucmModel{}, 1280, 1024, {f, f * 1.01, 640.2, 511.7, alpha, 1.0});
  const Camera mei(
      MeiModel{}, 1280, 1024,
      {f / (1 - alpha), f * 1.01 / (1 - alpha), 640.2, 511.7, alpha / (1 - alpha), 0, 0, 0, 0});
  std::mt19937 rng(10);
  for (const cv::Point3d& q : randomPoints(eucm, kPi, 500, rng)) {
    const Eigen::Vector3d point(q.x, q.y, q.z);
    const auto a = eucm.project(point);
    const auto b = mei.project(point);
    ASSERT_EQ(a.has_value(), b.has_value()) << point.transpose();
    if (a) {
      EXPECT_LT((*a - *b).norm(), 1e-9) << point.transpose();
    }
  }
}

TEST(CameraModelsTest, FovModelFollowsItsDefinition) {
  // r_d = atan(2 r tan(w / 2)) / w for a point at r = |(x, y)| / z.
  const double w = 0.9, f = 300.0;
  const Camera fov(FovModel{}, 640, 480, {f, f, 319.5, 239.5, w});
  for (double r : {0.0, 1e-9, 0.1, 0.5, 1.0, 3.0}) {
    const auto pixel = fov.project(Eigen::Vector3d(r, 0.0, 1.0));
    if (!pixel) continue;  // beyond the image border
    const double rd = r == 0.0 ? 0.0 : std::atan(2.0 * r * std::tan(w / 2)) / w;
    EXPECT_NEAR(pixel->x(), 319.5 + f * rd, 1e-9) << r;
  }
}

/// Compares the Jet derivatives of `model.project` with central differences,
/// with respect to the point and to every parameter. Derivatives are compared
/// scaled (pixels per relative change of the point, per `scales[i]` of
/// parameter i) to 1e-6 relative, 1e-6 px absolute.
template <typename Model>
void expectExactJacobians(const Model& model, const std::vector<double>& params,
                          const std::vector<double>& scales, const Eigen::Vector3d& point) {
  constexpr int kN = 40;
  using Jet = ceres::Jet<double, kN>;
  ASSERT_LE(params.size() + 3, static_cast<std::size_t>(kN));
  std::vector<Jet> params_jet(params.size());
  for (std::size_t i = 0; i < params.size(); ++i) {
    params_jet[i] = Jet(params[i], static_cast<int>(3 + i));
  }
  const Jet point_jet[3] = {Jet(point.x(), 0), Jet(point.y(), 1), Jet(point.z(), 2)};
  Jet pixel_jet[2];
  ASSERT_TRUE(model.project(params_jet.data(), point_jet, pixel_jet));

  const auto project = [&](const std::vector<double>& prm, const Eigen::Vector3d& q) {
    Eigen::Vector2d pixel;
    EXPECT_TRUE(model.project(prm.data(), q.data(), pixel.data()));
    return pixel;
  };
  const Eigen::Vector2d pixel = project(params, point);
  EXPECT_NEAR(pixel_jet[0].a, pixel.x(), 1e-9);
  EXPECT_NEAR(pixel_jet[1].a, pixel.y(), 1e-9);

  const auto compare = [&](int slot, double scale, const Eigen::Vector2d& numeric,
                           const std::string& what) {
    for (int r = 0; r < 2; ++r) {
      const double analytic = pixel_jet[r].v[slot] * scale;
      const double expected = numeric[r] * scale;
      EXPECT_NEAR(analytic, expected, 1e-6 * std::max(1.0, std::abs(expected)))
          << "d pixel[" << r << "] / d " << what << " (scaled by " << scale << ") at point "
          << point.transpose();
    }
  };
  const double point_scale = point.norm();
  for (int i = 0; i < 3; ++i) {
    const double h = 1e-5 * point_scale;
    Eigen::Vector3d plus = point, minus = point;
    plus[i] += h;
    minus[i] -= h;
    compare(i, point_scale, (project(params, plus) - project(params, minus)) / (2.0 * h),
            "point[" + std::to_string(i) + "]");
  }
  const std::vector<std::string> names = model.paramNames();
  for (std::size_t i = 0; i < params.size(); ++i) {
    const double h = 1e-5 * scales[i];
    std::vector<double> plus = params, minus = params;
    plus[i] += h;
    minus[i] -= h;
    compare(static_cast<int>(3 + i), scales[i],
            (project(plus, point) - project(minus, point)) / (2.0 * h), names[i]);
  }
}

TEST(CameraModelsTest, AutoDiffJacobiansMatchCentralDifferences) {
  std::mt19937 rng(8);
  for (CameraModelId id : kAllModels) {
    for (int trial = 0; trial < 3; ++trial) {
      const Camera camera = randomCamera(id, rng);
      SCOPED_TRACE(describe(camera));
      const std::vector<double> scales = paramScales(camera);
      for (int i = 0; i < 10; ++i) {
        const Eigen::Vector3d point = rayAt(uniform(rng, 0.02, 0.95 * camera.maxIncidenceAngle()),
                                            uniform(rng, 0.0, 2.0 * kPi)) *
                                      uniform(rng, 0.5, 5.0);
        std::visit(
            [&](const auto& model) { expectExactJacobians(model, camera.params(), scales, point); },
            camera.model());
      }
    }
  }
}

TEST(CameraModelsTest, ScaramuzzaJacobianOnTheOpticalAxis) {
  // OCamCalib's a1 = 0 makes the model smooth on the axis; the derivative
  // there is the pinhole one, d col / d x = -a0 / z (c = 1, d = e = 0).
  const std::vector<double> params =
      scaramuzzaParams(959.5, 539.5, 1.0, 0.0, 0.0, 540.0, 0.0, 1150.0, 10);
  using Jet = ceres::Jet<double, 3>;
  const Jet point[3] = {Jet(0.0, 0), Jet(0.0, 1), Jet(2.0, 2)};
  std::vector<Jet> params_jet(params.begin(), params.end());
  Jet pixel[2];
  const ScaramuzzaModel model{5, 10};
  ASSERT_TRUE(model.project(params_jet.data(), point, pixel));
  EXPECT_NEAR(pixel[0].a, 959.5, 1e-9);
  EXPECT_NEAR(pixel[1].a, 539.5, 1e-9);
  EXPECT_NEAR(pixel[0].v[0], -params[5] / 2.0, 1e-9);
  EXPECT_NEAR(pixel[1].v[1], -params[5] / 2.0, 1e-9);
  EXPECT_NEAR(pixel[0].v[1], 0.0, 1e-9);
  EXPECT_NEAR(pixel[0].v[2], 0.0, 1e-9);
}

}  // namespace
}  // namespace lookboth
