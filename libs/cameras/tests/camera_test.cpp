// The Camera class: validation messages, errors, image bounds, field of view,
// description.
#include "lookboth/cameras/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "lookboth/core/error.h"

namespace lookboth {
namespace {

bool startsWith(const std::string& text, const std::string& prefix) {
  return text.compare(0, prefix.size(), prefix) == 0;
}
bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

const std::vector<double> kPinhole = {500.0, 500.0, 319.5, 239.5};
const std::vector<double> kRadTan = {500.0, 501.0, 320.0, 240.0, -0.1, 0.02, 1e-4, -2e-4, 0.0};
const std::vector<double> kRational = {500.0, 501.0, 320.0, 240.0, 0.5,  0.1,
                                       1e-4,  -2e-4, 0.0,   0.6,   0.15, 0.0};
const std::vector<double> kKannalaBrandt = {540.0, 540.0, 959.5, 539.5, 0.02, -3e-3, 5e-4, -1e-4};
const std::vector<double> kDoubleSphere = {477.0, 477.0, 959.5, 539.5, -0.2, 0.6};
// -poly(rho) = 300 - rho^2 / 900: an equidistant-like fisheye, f = 300 px.
const std::vector<double> kScaramuzza = {959.5,  539.5, 1.0,         0.0, 0.0,
                                         -300.0, 0.0,   1.0 / 900.0, 0.0, 0.0};

TEST(CameraTest, ModelNamesAndIdentifiers) {
  EXPECT_EQ(cameraModelName(PinholeModel{}), "pinhole");
  EXPECT_EQ(cameraModelName(RadTanModel{}), "radtan");
  EXPECT_EQ(cameraModelName(RationalPolynomialModel{}), "rational_polynomial");
  EXPECT_EQ(cameraModelName(KannalaBrandtModel{}), "kannala_brandt");
  EXPECT_EQ(cameraModelName(ScaramuzzaModel{}), "scaramuzza");
  EXPECT_EQ(cameraModelName(DoubleSphereModel{}), "double_sphere");
  EXPECT_EQ(cameraModelId(RadTanModel{}), CameraModelId::kRadTan);
  EXPECT_EQ(cameraModelId(ScaramuzzaModel{}), CameraModelId::kScaramuzza);
  const Camera camera(DoubleSphereModel{}, 1920, 1080, kDoubleSphere);
  EXPECT_EQ(camera.modelId(), CameraModelId::kDoubleSphere);
  EXPECT_EQ(camera.modelName(), "double_sphere");
}

TEST(CameraTest, ParamNamesFollowTheDocumentedOrder) {
  using Names = std::vector<std::string>;
  EXPECT_EQ(Camera(PinholeModel{}, 640, 480, kPinhole).paramNames(),
            (Names{"fx", "fy", "cx", "cy"}));
  EXPECT_EQ(Camera(RadTanModel{}, 640, 480, kRadTan).paramNames(),
            (Names{"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"}));
  EXPECT_EQ(Camera(RationalPolynomialModel{}, 640, 480, kRational).paramNames(),
            (Names{"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"}));
  EXPECT_EQ(Camera(KannalaBrandtModel{}, 1920, 1080, kKannalaBrandt).paramNames(),
            (Names{"fx", "fy", "cx", "cy", "k1", "k2", "k3", "k4"}));
  EXPECT_EQ(Camera(DoubleSphereModel{}, 1920, 1080, kDoubleSphere).paramNames(),
            (Names{"fx", "fy", "cx", "cy", "xi", "alpha"}));
  std::vector<double> with_inverse = kScaramuzza;
  with_inverse.insert(with_inverse.end(), {471.2, 300.0});
  EXPECT_EQ(Camera(ScaramuzzaModel{5, 2}, 1920, 1080, with_inverse).paramNames(),
            (Names{"cx", "cy", "c", "d", "e", "a0", "a1", "a2", "a3", "a4", "inv0", "inv1"}));
  EXPECT_EQ(ScaramuzzaModel({3, 1}).numParams(), 9);
}

TEST(CameraTest, ValidateAcceptsUsableCameras) {
  EXPECT_EQ(Camera::validate(PinholeModel{}, 640, 480, kPinhole), "");
  EXPECT_EQ(Camera::validate(RadTanModel{}, 640, 480, kRadTan), "");
  EXPECT_EQ(Camera::validate(RationalPolynomialModel{}, 640, 480, kRational), "");
  EXPECT_EQ(Camera::validate(KannalaBrandtModel{}, 1920, 1080, kKannalaBrandt), "");
  EXPECT_EQ(Camera::validate(DoubleSphereModel{}, 1920, 1080, kDoubleSphere), "");
  EXPECT_EQ(Camera::validate(ScaramuzzaModel{5, 0}, 1920, 1080, kScaramuzza), "");
}

TEST(CameraTest, ValidateNamesTheOffendingParameter) {
  EXPECT_EQ(Camera::validate(PinholeModel{}, 640, 480, {-3.0, 500.0, 319.5, 239.5}),
            "'fx': must be positive, got -3");
  EXPECT_EQ(Camera::validate(KannalaBrandtModel{}, 1920, 1080,
                             {540.0, 0.0, 959.5, 539.5, 0.0, 0.0, 0.0, 0.0}),
            "'fy': must be positive, got 0");
  EXPECT_EQ(Camera::validate(PinholeModel{}, 640, 480, {500.0, 500.0, 700.0, 239.5}),
            "'cx': must lie inside the image [-0.5, 639.5], got 700");
  EXPECT_EQ(Camera::validate(RadTanModel{}, 640, 480, kPinhole),
            "'params': radtan needs 9 parameters (fx fy cx cy k1 k2 p1 p2 k3), got 4");
  std::vector<double> with_nan = kRadTan;
  with_nan[5] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_PRED2(startsWith, Camera::validate(RadTanModel{}, 640, 480, with_nan),
               "'k2': must be finite");
  EXPECT_EQ(Camera::validate(PinholeModel{}, 0, 480, kPinhole), "'width': must be positive, got 0");
  EXPECT_EQ(Camera::validate(PinholeModel{}, 640, -1, kPinhole),
            "'height': must be positive, got -1");
  EXPECT_EQ(Camera::validate(DoubleSphereModel{}, 1920, 1080, {477, 477, 959.5, 539.5, -0.2, 1.5}),
            "'alpha': must be in [0, 1], got 1.5");
  EXPECT_EQ(Camera::validate(DoubleSphereModel{}, 1920, 1080, {477, 477, 959.5, 539.5, -1.0, 0.6}),
            "'xi': must be in (-1, 1], got -1");
}

TEST(CameraTest, ValidateExplainsScaramuzzaMistakes) {
  std::vector<double> positive_a0 = kScaramuzza;
  positive_a0[5] = 300.0;
  EXPECT_PRED2(startsWith, Camera::validate(ScaramuzzaModel{5, 0}, 1920, 1080, positive_a0),
               "'a0': must be negative");
  positive_a0[5] = 0.0;
  EXPECT_PRED2(startsWith, Camera::validate(ScaramuzzaModel{5, 0}, 1920, 1080, positive_a0),
               "'a0': must be negative");
  EXPECT_PRED2(startsWith,
               Camera::validate(ScaramuzzaModel{1, 0}, 1920, 1080, {959.5, 539.5, 1, 0, 0, -300}),
               "'a'");
  EXPECT_PRED2(contains,
               Camera::validate(ScaramuzzaModel{1, 0}, 1920, 1080, {959.5, 539.5, 1, 0, 0, -300}),
               "at least 2");
  EXPECT_PRED2(startsWith, Camera::validate(ScaramuzzaModel{5, 2}, 1920, 1080, kScaramuzza),
               "'params': scaramuzza needs 12 parameters");
  std::vector<double> singular = kScaramuzza;
  singular[2] = 0.0;  // c - d e = 0
  EXPECT_PRED2(startsWith, Camera::validate(ScaramuzzaModel{5, 0}, 1920, 1080, singular), "'c':");
  std::vector<double> folded = kScaramuzza;
  folded[7] = -0.05;  // a2: the ray angle stops growing at rho = 77 px
  EXPECT_PRED2(startsWith, Camera::validate(ScaramuzzaModel{5, 0}, 1920, 1080, folded), "'a'");
  EXPECT_PRED2(contains, Camera::validate(ScaramuzzaModel{5, 0}, 1920, 1080, folded), "grow");
  std::vector<double> centre_outside = kScaramuzza;
  centre_outside[1] = 2000.0;
  EXPECT_PRED2(startsWith, Camera::validate(ScaramuzzaModel{5, 0}, 1920, 1080, centre_outside),
               "'cy':");
}

TEST(CameraTest, ConstructorThrowsLookbothErrorWithTheValidationMessage) {
  try {
    Camera camera(PinholeModel{}, 640, 480, {-3.0, 500.0, 319.5, 239.5});
    FAIL() << "no exception";
  } catch (const Error& error) {
    EXPECT_EQ(error.message(), "'fx': must be positive, got -3");
    EXPECT_PRED2(contains, error.what(), "'fx'");
  }
  EXPECT_THROW(Camera(RadTanModel{}, 640, 480, kPinhole), Error);
  EXPECT_THROW(Camera(DoubleSphereModel{}, 1920, 1080, {477, 477, 959.5, 539.5, -0.2, -0.1}),
               Error);
  EXPECT_NO_THROW(Camera(KannalaBrandtModel{}, 1920, 1080, kKannalaBrandt));
}

TEST(CameraTest, AccessorsReturnWhatWasGiven) {
  const Camera camera(RadTanModel{}, 640, 480, kRadTan);
  EXPECT_EQ(camera.width(), 640);
  EXPECT_EQ(camera.height(), 480);
  EXPECT_EQ(camera.params(), kRadTan);
  EXPECT_TRUE(std::holds_alternative<RadTanModel>(camera.model()));
}

TEST(CameraTest, IsInImageUsesThePixelCentreConvention) {
  const Camera camera(PinholeModel{}, 640, 480, kPinhole);
  EXPECT_TRUE(camera.isInImage({-0.5, -0.5}));
  EXPECT_TRUE(camera.isInImage({639.5, 479.5}));
  EXPECT_TRUE(camera.isInImage({0.0, 0.0}));
  EXPECT_FALSE(camera.isInImage({-0.51, 10.0}));
  EXPECT_FALSE(camera.isInImage({10.0, -0.51}));
  EXPECT_FALSE(camera.isInImage({639.51, 10.0}));
  EXPECT_FALSE(camera.isInImage({10.0, 479.51}));
  EXPECT_TRUE(camera.isInImage({0.5, 0.5}, 1.0));
  EXPECT_FALSE(camera.isInImage({0.4, 10.0}, 1.0));
  EXPECT_FALSE(camera.isInImage({638.6, 10.0}, 1.0));
  EXPECT_TRUE(camera.isInImage({638.5, 478.5}, 1.0));
  EXPECT_FALSE(camera.isInImage({std::numeric_limits<double>::quiet_NaN(), 10.0}));
}

TEST(CameraTest, PinholeFieldOfViewMatchesTheFocalLength) {
  // Horizontal is the widest direction: 2 atan(w / 2f).
  const Camera camera(PinholeModel{}, 640, 480, kPinhole);
  const double expected = 2.0 * std::atan(640.0 / (2.0 * 500.0));
  EXPECT_NEAR(camera.fieldOfView(), expected, 0.01 * expected);
  // A portrait image: vertical is the widest.
  const Camera portrait(PinholeModel{}, 480, 640, {500.0, 500.0, 239.5, 319.5});
  EXPECT_NEAR(portrait.fieldOfView(), expected, 0.01 * expected);
}

TEST(CameraTest, MaxIncidenceAngleCoversTheImageCornersWithAMargin) {
  const Camera camera(PinholeModel{}, 640, 480, kPinhole);
  const double corner = std::atan(std::hypot(320.0, 240.0) / 500.0);
  EXPECT_GE(camera.maxIncidenceAngle(), corner);
  EXPECT_LE(camera.maxIncidenceAngle(), 1.05 * corner + 1e-9);
  // Slightly outside the image: projects, but not into the image.
  const auto outside = camera.project({std::sin(corner + 0.01), 0.0, std::cos(corner + 0.01)});
  ASSERT_TRUE(outside);
  EXPECT_FALSE(camera.isInImage(*outside));
  // Far outside the image (and the margin): no pixel.
  EXPECT_FALSE(camera.project({std::sin(1.2 * corner), 0.0, std::cos(1.2 * corner)}));
  EXPECT_FALSE(camera.project({0.0, 0.0, -1.0}));
}

TEST(CameraTest, PrincipalPointAndOpticalAxis) {
  const Camera pinhole(PinholeModel{}, 640, 480, kPinhole);
  const auto pixel = pinhole.project({0.0, 0.0, 3.0});
  ASSERT_TRUE(pixel);
  EXPECT_NEAR((*pixel - Eigen::Vector2d(319.5, 239.5)).norm(), 0.0, 1e-12);
  const Camera scaramuzza(ScaramuzzaModel{5, 0}, 1920, 1080, kScaramuzza);
  const auto centre = scaramuzza.project({0.0, 0.0, 1.0});
  ASSERT_TRUE(centre);
  EXPECT_NEAR((*centre - Eigen::Vector2d(959.5, 539.5)).norm(), 0.0, 1e-9);
  const auto axis = scaramuzza.unproject({959.5, 539.5});
  ASSERT_TRUE(axis);
  EXPECT_NEAR((*axis - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12);
  // x right, y down: a point to the right and below the axis lands right and
  // below the centre, for every model.
  const std::vector<Camera> cameras = {
      pinhole, Camera(KannalaBrandtModel{}, 1920, 1080, kKannalaBrandt),
      Camera(DoubleSphereModel{}, 1920, 1080, kDoubleSphere), scaramuzza};
  for (const Camera& camera : cameras) {
    const auto c = camera.project({0.0, 0.0, 1.0});
    const auto p = camera.project({0.1, 0.05, 1.0});
    ASSERT_TRUE(c && p) << camera.description();
    EXPECT_GT(p->x(), c->x() + 10.0) << camera.description();
    EXPECT_GT(p->y(), c->y() + 5.0) << camera.description();
  }
}

TEST(CameraTest, DescriptionNamesModelSizeAndFieldOfView) {
  const Camera pinhole(PinholeModel{}, 640, 480, kPinhole);
  EXPECT_EQ(pinhole.description(), "pinhole 640x480 fov 65.2 deg");
  const Camera fisheye(KannalaBrandtModel{}, 1920, 1080, kKannalaBrandt);
  EXPECT_PRED2(startsWith, fisheye.description(), "kannala_brandt 1920x1080 fov ");
  EXPECT_GE(fisheye.fieldOfView(), 190.0 * kDeg);
}

}  // namespace
}  // namespace lookboth
