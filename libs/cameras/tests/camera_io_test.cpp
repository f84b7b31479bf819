// Tests of the camera calibration loaders and the lookboth YAML writer, on the
// sample files in tests/data/cameras (good and broken) and share/lookboth/cameras.
#include "lookboth/cameras/camera_io.h"

#include <gtest/gtest.h>
#include <mrpt/img/TCamera.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "lookboth/core/error.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

fs::path dataFile(const std::string& name) {
  return fs::path(LOOKBOTH_TEST_DATA_DIR) / "cameras" / name;
}
fs::path shareFile(const std::string& name) {
  return fs::path(LOOKBOTH_SHARE_DIR) / "cameras" / name;
}

/// Loads `path` and expects a lookboth::Error whose message contains every
/// one of `needles` (the file name is always checked). Returns the error.
Error expectLoadError(const fs::path& path, const std::vector<std::string>& needles,
                      CameraFileFormat format = CameraFileFormat::kAuto,
                      const std::string& camera = "") {
  try {
    loadCamera(path, format, camera);
  } catch (const Error& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find(path.filename().string()), std::string::npos) << what;
    for (const std::string& needle : needles) {
      EXPECT_NE(what.find(needle), std::string::npos) << "'" << needle << "' not in: " << what;
    }
    return error;
  } catch (const std::exception& other) {
    ADD_FAILURE() << "not a lookboth::Error: " << other.what();
    return Error("");
  }
  ADD_FAILURE() << "no error loading " << path;
  return Error("");
}

void expectParams(const Camera& camera, const std::string& model, int width, int height,
                  const std::vector<double>& params) {
  EXPECT_EQ(camera.modelName(), model);
  EXPECT_EQ(camera.width(), width);
  EXPECT_EQ(camera.height(), height);
  EXPECT_EQ(camera.params(), params);  // exact: decimal text parsed to the nearest double
}

/// A fresh empty directory, removed at the end of the test.
class TempDir {
 public:
  explicit TempDir(const std::string& name)
      : path_(fs::temp_directory_path() /
              ("lookboth_camera_io_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// ---------------------------------------------------------------------------
// Format detection

TEST(CameraIo, DetectsFormatsByContents) {
  const std::vector<std::pair<fs::path, CameraFileFormat>> cases = {
      {shareFile("fisheye_kannala_brandt.yaml"), CameraFileFormat::kLookboth},
      {shareFile("fisheye_double_sphere.yaml"), CameraFileFormat::kLookboth},
      {dataFile("lookboth_scaramuzza.yaml"), CameraFileFormat::kLookboth},
      {shareFile("ceiling_camera_ros.yaml"), CameraFileFormat::kRosCameraInfo},
      {dataFile("ros_equidistant.yaml"), CameraFileFormat::kRosCameraInfo},
      {shareFile("kalibr_camchain.yaml"), CameraFileFormat::kKalibr},
      {dataFile("kalibr_models.yaml"), CameraFileFormat::kKalibr},
      {shareFile("fisheye_calib_results.txt"), CameraFileFormat::kOCamCalib},
      {dataFile("ocam_small_crlf.txt"), CameraFileFormat::kOCamCalib},
      {shareFile("ceiling_camera_opencv.yaml"), CameraFileFormat::kOpenCV},
      {shareFile("fisheye_opencv.xml"), CameraFileFormat::kOpenCV},
      {dataFile("opencv_rational.xml"), CameraFileFormat::kOpenCV},
  };
  for (const auto& [path, format] : cases) {
    EXPECT_EQ(cameraFileFormatName(detectCameraFileFormat(path)), cameraFileFormatName(format))
        << path;
  }
}

TEST(CameraIo, UnknownFormatAndMissingFileAreErrors) {
  expectLoadError(dataFile("unknown_format.txt"), {"not a camera calibration file"});
  EXPECT_THROW(detectCameraFileFormat(dataFile("unknown_format.txt")), Error);
  for (const CameraFileFormat format :
       {CameraFileFormat::kAuto, CameraFileFormat::kLookboth, CameraFileFormat::kRosCameraInfo,
        CameraFileFormat::kKalibr, CameraFileFormat::kOCamCalib, CameraFileFormat::kOpenCV}) {
    expectLoadError(dataFile("no_such_calibration.yaml"), {}, format);
  }
  EXPECT_THROW(loadKalibrCamchain(dataFile("no_such_camchain.yaml")), Error);
}

// ---------------------------------------------------------------------------
// lookboth YAML

TEST(CameraIo, LoadsLookbothYaml) {
  expectParams(
      loadCamera(dataFile("lookboth_radtan.yaml")), "radtan", 1920, 1080,
      {1052.731, 1051.942, 963.184, 541.826, -0.341237, 0.137514, 0.000421, -0.000308, -0.026813});
  expectParams(loadCamera(shareFile("fisheye_kannala_brandt.yaml"), CameraFileFormat::kLookboth),
               "kannala_brandt", 1920, 1080,
               {599.9858, 600.1280, 962.371094, 536.843217, -0.0124, 0.0031, -0.00072, 0.000058});
  expectParams(loadCamera(shareFile("fisheye_double_sphere.yaml")), "double_sphere", 1920, 1080,
               {419.7966, 419.8961, 962.371094, 536.843217, -0.303131, 0.562042});
  const Camera scaramuzza = loadCamera(dataFile("lookboth_scaramuzza.yaml"));
  expectParams(
      scaramuzza, "scaramuzza", 640, 480,
      {322.547,       241.218,        1.000237,    -0.000184,  0.000291,   -181.8652, 0,
       2.0950698e-03, -2.2647843e-06, 1.10965e-08, 279.455481, 173.670026, 6.802589,  21.381605,
       14.100696,     1.512067,       2.377990,    5.257552,   2.756879,   0.443151});
  EXPECT_EQ(std::get<ScaramuzzaModel>(scaramuzza.model()).num_poly, 5);
  EXPECT_EQ(std::get<ScaramuzzaModel>(scaramuzza.model()).num_inv_poly, 10);
}

TEST(CameraIo, LookbothYamlErrorsNameTheField) {
  expectLoadError(dataFile("lookboth_unknown_model.yaml"),
                  {"'model'", "fisheye624", "kannala_brandt"});
  expectLoadError(dataFile("lookboth_missing_param.yaml"), {"'params.k2'", "missing"});
  expectLoadError(dataFile("lookboth_extra_param.yaml"),
                  {"'params.k5'", ":16:", "unknown parameter"});
  expectLoadError(dataFile("lookboth_bad_number.yaml"), {"'params.fx'", "1O52.731", ":9:"});
  expectLoadError(dataFile("lookboth_syntax_error.yaml"), {"YAML syntax error"});
  EXPECT_THROW(cameraFromYaml("lookboth_camera: 2\nmodel: pinhole\n", "inline"), Error);
  EXPECT_THROW(cameraFromYaml("", "inline"), Error);
  try {
    cameraFromYaml(
        "lookboth_camera: 1\nmodel: pinhole\nwidth: 640\nheight: 480\n"
        "params: {fx: -500, fy: 500, cx: 319.5, cy: 239.5}\n",
        "negative_focal.yaml");
    FAIL() << "negative focal length accepted";
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("negative_focal.yaml"), std::string::npos)
        << error.what();
    EXPECT_NE(std::string(error.what()).find("fx"), std::string::npos) << error.what();
  }
  EXPECT_THROW(
      cameraFromYaml("lookboth_camera: 1\nmodel: pinhole\nwidth: 640\nheight: 480\nwidht: 1\n"
                     "params: {fx: 500, fy: 500, cx: 319.5, cy: 239.5}\n",
                     "typo.yaml"),
      Error);
}

/// One camera of every model, with parameters that need all 17 digits.
std::vector<Camera> camerasOfEveryModel() {
  const double third = 1.0 / 3.0;
  std::vector<Camera> cameras;
  cameras.emplace_back(PinholeModel{}, 640, 480,
                       std::vector<double>{500.0 + third, 499.0 + 1.0 / 7.0, 319.5 + 1e-9 * third,
                                           239.5 + M_PI / 10});
  cameras.emplace_back(RadTanModel{}, 1920, 1080,
                       std::vector<double>{1052.731 + third, 1051.942, 963.184 + 1.0 / 7.0, 541.826,
                                           -0.341237 * third, 0.137514 / 7.0, 0.000421 * third,
                                           -0.000308, -0.026813 / 3.0});
  cameras.emplace_back(
      RationalPolynomialModel{}, 1280, 720,
      std::vector<double>{702.5 + third, 701.75, 641.25, 359.5 + third, 2.5 + third, 1.25,
                          0.001 * third, -0.002, 0.0625 / 7.0, 2.75 + third, 1.5, 0.125 / 3.0});
  cameras.emplace_back(KannalaBrandtModel{}, 1920, 1080,
                       std::vector<double>{544.9871 + third, 545.1163, 962.371094 / 1.1 * 1.1,
                                           536.843217 + 1.0 / 7.0, -0.0124 * third, 0.0031,
                                           -0.00072 / 7.0, 0.000058 * third});
  cameras.emplace_back(
      DoubleSphereModel{}, 1920, 1080,
      std::vector<double>{381.3152 + third, 381.4056, 962.371094, 536.843217 + third,
                          -0.303131 * (1 + 1e-10 * third), 0.562042 + 1e-12 * third});
  const Camera ocam = loadCamera(shareFile("fisheye_calib_results.txt"));
  std::vector<double> params = ocam.params();
  for (double& value : params) value *= 1.0 + 1e-12 * third;
  cameras.emplace_back(ocam.model(), ocam.width(), ocam.height(), params);
  return cameras;
}

TEST(CameraIo, LookbothYamlRoundTripIsBitExactForEveryModel) {
  TempDir dir("round_trip");
  for (const Camera& camera : camerasOfEveryModel()) {
    SCOPED_TRACE(camera.modelName());
    const Camera from_string = cameraFromYaml(cameraToYaml(camera), "string");
    expectParams(from_string, camera.modelName(), camera.width(), camera.height(), camera.params());

    const fs::path path = dir.path() / (camera.modelName() + ".yaml");
    saveCamera(camera, path);
    // Written atomically: the destination and nothing else (no temporary left).
    std::vector<fs::path> entries;
    for (const auto& entry : fs::directory_iterator(dir.path())) entries.push_back(entry.path());
    ASSERT_EQ(entries.size(), 1u);
    EXPECT_EQ(entries.front(), path);
    EXPECT_EQ(cameraFileFormatName(detectCameraFileFormat(path)), "lookboth");
    const Camera loaded = loadCamera(path);
    expectParams(loaded, camera.modelName(), camera.width(), camera.height(), camera.params());
    // Saving again replaces the file.
    saveCamera(loaded, path);
    expectParams(loadCamera(path), camera.modelName(), camera.width(), camera.height(),
                 camera.params());
    fs::remove(path);
  }
  EXPECT_THROW(
      saveCamera(camerasOfEveryModel().front(), dir.path() / "no_such_dir" / "camera.yaml"), Error);
}

// ---------------------------------------------------------------------------
// ROS camera_info

TEST(CameraIo, LoadsRosCameraInfo) {
  expectParams(
      loadCamera(shareFile("ceiling_camera_ros.yaml")), "radtan", 1920, 1080,
      {1052.731, 1051.942, 963.184, 541.826, -0.341237, 0.137514, 0.000421, -0.000308, -0.026813});
  expectParams(loadCamera(dataFile("ros_equidistant.yaml"), CameraFileFormat::kRosCameraInfo),
               "kannala_brandt", 1920, 1080,
               {544.9871, 545.1163, 962.371094, 536.843217, -0.0124, 0.0031, -0.00072, 0.000058});
  expectParams(loadCamera(dataFile("ros_rational.yaml")), "rational_polynomial", 1280, 720,
               {702.5, 701.75, 641.25, 359.5, 2.5, 1.25, 0.001, -0.002, 0.0625, 2.75, 1.5, 0.125});
}

TEST(CameraIo, RosCameraInfoErrorsNameTheField) {
  expectLoadError(dataFile("ros_skew.yaml"),
                  {"'camera_matrix.data'", "skew", ":7:", "ceiling_cam_07"});
  expectLoadError(dataFile("ros_wrong_count.yaml"),
                  {"'distortion_coefficients.data'", "1 x 4", "5 numbers"});
  expectLoadError(
      dataFile("ros_unknown_model.yaml"),
      {"'distortion_model'", "fisheye624", "plumb_bob, rational_polynomial, equidistant"});
  // Another format read as ROS: the missing field is named.
  expectLoadError(dataFile("lookboth_radtan.yaml"), {"'image_width'", "missing"},
                  CameraFileFormat::kRosCameraInfo);
}

// ---------------------------------------------------------------------------
// Kalibr

TEST(CameraIo, LoadsKalibrCamchain) {
  const std::map<std::string, Camera> cameras = loadKalibrCamchain(dataFile("kalibr_models.yaml"));
  ASSERT_EQ(cameras.size(), 4u);
  expectParams(
      cameras.at("cam0"), "radtan", 752, 480,
      {461.629, 460.152, 362.680, 246.049, -0.27695497, 0.06712482, 0.00087538, 0.00011556, 0.0});
  expectParams(cameras.at("cam1"), "kannala_brandt", 1024, 1024,
               {380.81, 380.71, 510.29, 514.38, 0.0101, -0.0037, 0.0012, -0.0002});
  expectParams(cameras.at("cam2"), "pinhole", 640, 480, {500.0, 500.0, 319.5, 239.5});
  // Kalibr's ds intrinsics [xi alpha fu fv pu pv] -> fx fy cx cy xi alpha.
  expectParams(cameras.at("cam3"), "double_sphere", 1280, 1024,
               {350.5, 350.25, 639.5, 511.5, -0.2, 0.6});

  expectParams(loadCamera(dataFile("kalibr_models.yaml"), CameraFileFormat::kAuto, "cam3"),
               "double_sphere", 1280, 1024, {350.5, 350.25, 639.5, 511.5, -0.2, 0.6});
  // No name: the first camera.
  EXPECT_EQ(loadCamera(dataFile("kalibr_models.yaml")).modelName(), "radtan");

  const std::map<std::string, Camera> share = loadKalibrCamchain(shareFile("kalibr_camchain.yaml"));
  ASSERT_EQ(share.size(), 2u);
  expectParams(share.at("cam0"), "double_sphere", 1920, 1080,
               {419.7966, 419.8961, 962.371094, 536.843217, -0.303131, 0.562042});
  expectParams(
      share.at("cam1"), "radtan", 1280, 720,
      {642.8173, 641.9352, 633.4518, 362.0874, -0.2981342, 0.0873158, 0.0003127, -0.0005213, 0.0});
}

TEST(CameraIo, LoadsKalibrUnifiedModelsAndFov) {
  const fs::path file = dataFile("kalibr_unified_models.yaml");
  // eucm [alpha beta fu fv pu pv] -> fx fy cx cy alpha beta.
  expectParams(loadCamera(file, CameraFileFormat::kAuto, "cam0"), "eucm", 512, 512,
               {191.25, 191.5, 254.75, 256.5, 0.63, 1.04});
  // omni [xi fu fv pu pv] + radtan [k1 k2 p1 p2] -> fx fy cx cy xi k1 k2 p1 p2.
  expectParams(loadCamera(file, CameraFileFormat::kAuto, "cam1"), "mei", 1280, 1024,
               {750.5, 751.25, 639.5, 511.75, 1.5, -0.25, 0.0625, 0.001, -0.0005});
  expectParams(loadCamera(file, CameraFileFormat::kAuto, "cam2"), "mei", 640, 480,
               {500.5, 500.25, 319.5, 239.5, 0.75, 0.0, 0.0, 0.0, 0.0});
  // pinhole-fov [w] -> fx fy cx cy w.
  expectParams(loadCamera(file, CameraFileFormat::kAuto, "cam3"), "fov", 640, 480,
               {280.5, 280.25, 320.5, 240.25, 0.875});
  expectLoadError(file, {"cam4.distortion_coeffs", "omni-radtan needs 4 numbers", "got 3"},
                  CameraFileFormat::kAuto, "cam4");
  expectLoadError(file, {"cam5.distortion_model", "eucm-radtan", "is not supported", "omni-radtan"},
                  CameraFileFormat::kAuto, "cam5");
}

TEST(CameraIo, LoadsCamOdoCalFiles) {
  // Real files of VINS-Fusion (tests/data/cameras/real/euroc_cam0/SOURCE.md).
  const fs::path real = fs::path(LOOKBOTH_TEST_DATA_DIR) / "cameras" / "real" / "euroc_cam0";
  EXPECT_EQ(detectCameraFileFormat(real / "cam0_mei.yaml"), CameraFileFormat::kCamOdoCal);
  expectParams(loadCamera(real / "cam0_mei.yaml"), "mei", 752, 480,
               {2.1387619122017772e+03, 2.1315886210259278e+03, 3.6119856633263799e+02,
                2.4827644773395667e+02, 3.6313355285286337e+00, 1.1757726639872075e+00,
                1.5491281051140213e+01, -8.1237172954550494e-04, 6.7297684030310243e-04});
  expectParams(loadCamera(real / "cam0_pinhole.yaml"), "radtan", 752, 480,
               {4.6170381623421628e+02, 4.6043378588777085e+02, 3.6322379726457223e+02,
                2.4818637846327383e+02, -2.9250563288482467e-01, 8.3305380138632271e-02,
                2.4650824570721693e-05, -1.1770093773613896e-04, 0.0});
  // CamOdoCal's k2..k5 are the coefficients of theta^3 .. theta^9: kannala_brandt's k1..k4.
  expectParams(loadCamera(dataFile("camodocal_kannala_brandt.yaml")), "kannala_brandt", 1024, 768,
               {380.5, 380.25, 511.5, 383.75, 0.0125, -0.00375, 0.00125, -0.0003125});
  expectLoadError(dataFile("camodocal_scaramuzza.yaml"),
                  {"'model_type'", "SCARAMUZZA", "MEI, PINHOLE, KANNALA_BRANDT"});
  expectLoadError(dataFile("camodocal_mei_missing_gamma.yaml"),
                  {"projection_parameters.gamma1", "missing"});
}

TEST(CameraIo, KalibrErrorsNameTheCameraAndField) {
  expectLoadError(
      dataFile("kalibr_omni.yaml"),
      {"'cam2.camera_model'", "fisheye624-none", "not supported", "pinhole-radtan", "omni-radtan"},
      CameraFileFormat::kKalibr, "cam2");
  EXPECT_THROW(loadKalibrCamchain(dataFile("kalibr_omni.yaml")), Error);
  // Its cam1, Kalibr's omni-radtan, is Mei's model.
  EXPECT_EQ(loadCamera(dataFile("kalibr_omni.yaml"), CameraFileFormat::kKalibr, "cam1").modelName(),
            "mei");
  // cam0 of that file is fine.
  EXPECT_EQ(loadCamera(dataFile("kalibr_omni.yaml")).modelName(), "pinhole");
  expectLoadError(dataFile("kalibr_wrong_count.yaml"),
                  {"'cam0.distortion_coeffs'", "4", "got 5", ":5:"});
  expectLoadError(dataFile("kalibr_models.yaml"), {"'cam7'", "cam0, cam1, cam2, cam3"},
                  CameraFileFormat::kKalibr, "cam7");
}

// ---------------------------------------------------------------------------
// OCamCalib

TEST(CameraIo, LoadsOCamCalib) {
  // Centre "row column" = 536.843217 962.371094 -> cx = column, cy = row.
  const Camera fisheye = loadCamera(shareFile("fisheye_calib_results.txt"));
  expectParams(
      fisheye, "scaramuzza", 1920, 1080,
      {962.371094,   536.843217,    1.000237,     -0.000184,  0.000291,   -6.007053e+02, 0.0,
       6.374789e-04, -2.165792e-07, 3.143252e-10, 922.868071, 572.660172, 20.851408,     70.117927,
       46.557149,    4.307284,      8.077259,     18.688423,  9.975524,   1.638084});
  EXPECT_EQ(std::get<ScaramuzzaModel>(fisheye.model()).num_poly, 5);
  EXPECT_EQ(std::get<ScaramuzzaModel>(fisheye.model()).num_inv_poly, 10);

  // CRLF line endings, explicit format.
  expectParams(
      loadCamera(dataFile("ocam_small_crlf.txt"), CameraFileFormat::kOCamCalib), "scaramuzza", 640,
      480,
      {322.547,      241.218,       1.000237,     -0.000184,  0.000291,   -1.818652e+02, 0.0,
       2.095070e-03, -2.264784e-06, 1.109650e-08, 279.455481, 173.670026, 6.802589,      21.381605,
       14.100696,    1.512067,      2.377990,     5.257552,   2.756879,   0.443151});
}

TEST(CameraIo, OCamCalibErrorsNameTheLineAndBlock) {
  const Error short_poly = expectLoadError(
      dataFile("ocam_short_poly.txt"),
      {":3:", "'polynomial coefficients'", "expected 5 numbers after the count, got 4"});
  EXPECT_EQ(short_poly.context().line, 3);
  expectLoadError(dataFile("ocam_bad_number.txt"), {":11:", "'center'", "322.5x7"});
  expectLoadError(dataFile("ocam_truncated.txt"), {"'affine parameters'", "missing"});
  expectLoadError(dataFile("lookboth_radtan.yaml"), {":2:", "'polynomial coefficients'"},
                  CameraFileFormat::kOCamCalib);
}

/// OCamCalib's world2cam with the inverse polynomial, written from the
/// published model: OCamCalib frame x_o = our y, y_o = our x, z_o = -our z;
/// theta = atan(z_o / |(x_o, y_o)|), rho = sum inv_i theta^i,
/// row = c x + d y + row0, column = e x + y + col0. Returns (column, row).
Eigen::Vector2d ocamWorld2Cam(const Camera& camera, const Eigen::Vector3d& direction) {
  const std::vector<double>& p = camera.params();
  const auto& model = std::get<ScaramuzzaModel>(camera.model());
  const double xo = direction.y();
  const double yo = direction.x();
  const double zo = -direction.z();
  const double norm = std::hypot(xo, yo);
  const double theta = std::atan(zo / norm);
  double rho = 0.0;
  double power = 1.0;
  for (int i = 0; i < model.num_inv_poly; ++i) {
    rho += p[static_cast<size_t>(5 + model.num_poly + i)] * power;
    power *= theta;
  }
  const double x = xo / norm * rho;
  const double y = yo / norm * rho;
  return {p[4] * x + y + p[0], p[2] * x + p[3] * y + p[1]};
}

Eigen::Vector3d direction(double incidence, double azimuth) {
  return {std::sin(incidence) * std::cos(azimuth), std::sin(incidence) * std::sin(azimuth),
          std::cos(incidence)};
}

TEST(CameraIo, OCamCalibShareSampleIsConsistent) {
  const Camera camera = loadCamera(shareFile("fisheye_calib_results.txt"));
  // The distortion centre looks along the optical axis.
  const auto axis = camera.unproject({962.371094, 536.843217});
  ASSERT_TRUE(axis.has_value());
  EXPECT_NEAR(axis->z(), 1.0, 1e-12);

  // project(unproject(pixel)) == pixel over the image.
  int checked = 0;
  for (double v = 0.0; v <= 1079.0; v += 53.9) {
    for (double u = 0.0; u <= 1919.0; u += 95.9) {
      const Eigen::Vector2d pixel(u, v);
      const auto ray = camera.unproject(pixel);
      if (!ray) continue;
      const auto back = camera.project(*ray);
      ASSERT_TRUE(back.has_value()) << pixel.transpose();
      EXPECT_LT((*back - pixel).norm(), 1e-6) << pixel.transpose();
      ++checked;
    }
  }
  EXPECT_GT(checked, 300);

  // The file's inverse polynomial agrees with the direct one (through
  // Camera::project) to well under a pixel, up to 95 deg from the axis.
  double worst = 0.0;
  for (double incidence = 0.02; incidence <= 95.0 * M_PI / 180.0; incidence += 0.05) {
    for (double azimuth = 0.0; azimuth < 2.0 * M_PI; azimuth += 0.4) {
      const Eigen::Vector3d d = direction(incidence, azimuth);
      const auto projected = camera.project(d);
      ASSERT_TRUE(projected.has_value()) << incidence;
      worst = std::max(worst, (*projected - ocamWorld2Cam(camera, d)).norm());
    }
  }
  EXPECT_LT(worst, 0.5);
}

TEST(CameraIo, FisheyeSamplesDescribeTheSameLens) {
  const Camera ocam = loadCamera(shareFile("fisheye_calib_results.txt"));
  const Camera kb = loadCamera(shareFile("fisheye_kannala_brandt.yaml"));
  const Camera ds = loadCamera(shareFile("fisheye_double_sphere.yaml"));
  const Camera kb_xml = loadCamera(shareFile("fisheye_opencv.xml"));
  EXPECT_EQ(kb_xml.params(), kb.params());
  for (double incidence = 0.1; incidence <= 90.0 * M_PI / 180.0; incidence += 0.1) {
    for (double azimuth = 0.0; azimuth < 2.0 * M_PI; azimuth += 0.7) {
      const Eigen::Vector3d d = direction(incidence, azimuth);
      const auto a = ocam.project(d);
      const auto b = kb.project(d);
      const auto c = ds.project(d);
      ASSERT_TRUE(a && b && c);
      EXPECT_LT((*a - *b).norm(), 4.0) << incidence;
      EXPECT_LT((*c - *b).norm(), 4.0) << incidence;
    }
  }
}

// ---------------------------------------------------------------------------
// OpenCV FileStorage

TEST(CameraIo, LoadsOpenCvFileStorage) {
  expectParams(
      loadCamera(shareFile("ceiling_camera_opencv.yaml")), "radtan", 1920, 1080,
      {1047.382, 1046.917, 958.614, 545.207, -0.336129, 0.129843, -0.000217, 0.000386, -0.023471});
  // fisheye_model: 1 (OpenCV's calibration sample) marks the 4 coefficients as fisheye.
  expectParams(loadCamera(shareFile("fisheye_opencv.xml"), CameraFileFormat::kOpenCV),
               "kannala_brandt", 1920, 1080,
               {599.9858, 600.1280, 962.371094, 536.843217, -0.0124, 0.0031, -0.00072, 0.000058});
  expectParams(loadCamera(dataFile("opencv_fisheye_named.yaml")), "kannala_brandt", 1920, 1080,
               {545.5, 545.25, 960.5, 540.5, -0.0125, 0.003125, -0.00075, 0.0000625});
  expectParams(loadCamera(dataFile("opencv_rational.xml")), "rational_polynomial", 1280, 720,
               {702.5, 701.75, 641.25, 359.5, 2.5, 1.25, 0.001, -0.002, 0.0625, 2.75, 1.5, 0.125});
  expectParams(loadCamera(dataFile("opencv_radtan.yaml")), "radtan", 1920, 1080,
               {1050.5, 1049.75, 960.25, 540.125, -0.25, 0.0625, 0.001, -0.0005, -0.015625});
  expectParams(loadCamera(dataFile("opencv_pinhole.yaml")), "pinhole", 640, 480,
               {500, 500, 319.5, 239.5});
}

TEST(CameraIo, OpenCvErrorsNameTheField) {
  expectLoadError(dataFile("opencv_thin_prism.yaml"),
                  {"'distortion_coefficients'", "thin prism / tilted"});
  expectLoadError(dataFile("opencv_no_size.yaml"), {"'image_width'", "missing"});
  expectLoadError(dataFile("opencv_four_ambiguous.yaml"), {"'distortion_coefficients'", "fisheye"});
  expectLoadError(dataFile("opencv_syntax_error.xml"), {"OpenCV could not read it"});
  expectLoadError(dataFile("ocam_small_crlf.txt"), {}, CameraFileFormat::kOpenCV);
}

// ---------------------------------------------------------------------------
// Broken or hostile files: deep nesting, repeated keys, huge values

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

fs::path writeText(const TempDir& dir, const std::string& name, const std::string& text) {
  const fs::path path = dir.path() / name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

std::string repeat(const std::string& unit, size_t count) {
  std::string out;
  out.reserve(unit.size() * count);
  for (size_t i = 0; i < count; ++i) out += unit;
  return out;
}

// Far more levels than OpenCV's recursive readers survive on an 8 MB stack.
constexpr size_t kDeep = 100000;

TEST(CameraIo, DeeplyNestedFilesAreErrorsNotCrashes) {
  TempDir dir("deep");
  const std::string yaml = "%YAML:1.0\n---\nimage_width: 10\nimage_height: 10\n";
  const std::string xml = "<?xml version=\"1.0\"?>\n<opencv_storage>\n";
  struct Case {
    std::string name;
    std::string text;
    CameraFileFormat format;
    int line;  // where the 65th level opens
  };
  const std::vector<Case> cases = {
      // OpenCV's YAML: flow collections, and the block collections it nests on
      // one line ("- - -", "a: a: a:", "-----", and with a tag before each).
      {"flow_seq.yaml", yaml + "x: " + repeat("[", kDeep) + repeat("]", kDeep) + "\n",
       CameraFileFormat::kAuto, 5},
      {"flow_map.yaml", yaml + "x: " + repeat("{a: ", kDeep) + "1" + repeat("}", kDeep) + "\n",
       CameraFileFormat::kAuto, 5},
      {"block_seq.yaml", yaml + "x:\n  " + repeat("- ", kDeep) + "1\n", CameraFileFormat::kAuto, 6},
      {"keys.yaml", yaml + "x: " + repeat("a: ", kDeep) + "1\n", CameraFileFormat::kAuto, 5},
      {"dashes.yaml", yaml + "x: " + repeat("-", kDeep) + "a\n", CameraFileFormat::kAuto, 5},
      {"tags.yaml", yaml + "x: " + repeat("!t - ", kDeep) + "1\n", CameraFileFormat::kAuto, 5},
      {"elements.xml",
       xml + repeat("<a>", kDeep) + "1" + repeat("</a>", kDeep) + "\n</opencv_storage>\n",
       CameraFileFormat::kAuto, 3},
      // JSON: cv::FileStorage reads it when the format is given as OpenCV.
      {"arrays.json", "{\"x\": " + repeat("[", kDeep) + repeat("]", kDeep) + "}\n",
       CameraFileFormat::kOpenCV, 1},
      // The formats yaml-cpp reads.
      {"lookboth.yaml",
       "lookboth_camera: 1\nmodel: pinhole\nwidth: " + repeat("[", kDeep) + repeat("]", kDeep) +
           "\n",
       CameraFileFormat::kAuto, 3},
      {"ros.yaml", "image_width: 10\ncamera_matrix:\n  " + repeat("- ", kDeep) + "1\n",
       CameraFileFormat::kRosCameraInfo, 3},
      {"kalibr.yaml", "cam0: " + repeat("{a: ", kDeep) + "1" + repeat("}", kDeep) + "\n",
       CameraFileFormat::kAuto, 1},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Error error = expectLoadError(writeText(dir, c.name, c.text),
                                        {"nesting deeper than 64 levels"}, c.format);
    EXPECT_EQ(error.context().line, c.line);
  }
  EXPECT_THROW(loadKalibrCamchain(dir.path() / "kalibr.yaml"), Error);
}

TEST(CameraIo, NestingUpToTheLimitLoads) {
  TempDir dir("limit");
  // The root collection and `extra` levels more.
  auto yamlWith = [](const fs::path& sample, size_t extra) {
    return readText(sample) + "extra: " + repeat("[", extra) + repeat("]", extra) + "\n";
  };
  auto xmlWith = [](const fs::path& sample, size_t extra) {
    std::string text = readText(sample);
    const std::string nested = repeat("<a>", extra) + "1" + repeat("</a>", extra) + "\n";
    return text.insert(text.rfind("</opencv_storage>"), nested);
  };
  const std::vector<std::pair<std::string, std::function<std::string(const fs::path&, size_t)>>>
      samples = {{"ros_rational.yaml", yamlWith},
                 {"opencv_pinhole.yaml", yamlWith},
                 {"opencv_rational.xml", xmlWith}};
  for (const auto& [name, with] : samples) {
    SCOPED_TRACE(name);
    const Camera at_limit = loadCamera(writeText(dir, "63_" + name, with(dataFile(name), 63)));
    EXPECT_EQ(at_limit.params(), loadCamera(dataFile(name)).params());
    expectLoadError(writeText(dir, "64_" + name, with(dataFile(name), 64)),
                    {"nesting deeper than 64 levels"});
  }
}

TEST(CameraIo, BracketsInStringsCommentsAndEntitiesOpenNothing) {
  TempDir dir("not_nesting");
  std::string yaml = readText(dataFile("opencv_pinhole.yaml"));
  yaml += "# " + repeat("[{", 200) + "\n";
  yaml += "note: '" + repeat("[", 200) + "'\n";
  yaml += "other: \"" + repeat("{", 200) + "\" # " + repeat("-", 200) + "\n";
  expectParams(loadCamera(writeText(dir, "strings.yaml", yaml)), "pinhole", 640, 480,
               {500, 500, 319.5, 239.5});
  std::string xml = readText(dataFile("opencv_rational.xml"));
  xml.insert(xml.rfind("</opencv_storage>"), "<!-- " + repeat("<a>", 200) + " -->\n<note>" +
                                                 repeat("&lt;a&gt;", 200) + "</note>\n");
  EXPECT_EQ(loadCamera(writeText(dir, "entities.xml", xml)).params(),
            loadCamera(dataFile("opencv_rational.xml")).params());
  // Matrices written by OpenCV in base64 ("!!binary", type_id="binary").
  for (const char* name : {"opencv_base64.yaml", "opencv_base64.xml"}) {
    expectParams(loadCamera(dataFile(name)), "radtan", 640, 480,
                 {500, 500, 319.5, 239.5, -0.25, 0.0625, 0.001, -0.0005, -0.015625});
  }
}

TEST(CameraIo, TextThatWouldCrashOrHangOpenCvIsAnError) {
  TempDir dir("traps");
  const std::string yaml = "%YAML:1.0\n---\nimage_width: 10\nimage_height: 10\n";
  // Base64 whose 24-byte header is all spaces: a type spec naming no type.
  const std::string spaces = repeat("ICAg", 12);
  struct Case {
    std::string name;
    std::string text;
    std::string needle;
    int line;
  };
  const std::vector<Case> cases = {
      // OpenCV dereferences a null pointer when the text ends after "=".
      {"attribute.xml",
       "<?xml version=\"1.0\"?>\n<opencv_storage>\n<a b=", "where OpenCV's reader would crash", 3},
      // A document after the first that does not start with "---": OpenCV
      // loops forever.
      {"documents.yaml", "%YAML:1.0\n---\n[1]\n...\n-x\n", "would never finish", 5},
      // After the first document OpenCV skips three characters, here past
      // the end of the line, and reads on in what the longer line before
      // left in its buffer: 100000 brackets.
      {"stale.yaml", "%YAML:1.0\n---\n[a, ---" + repeat("[", kDeep) + "]\nx\ny: 1\n",
       "past the end of this line", 4},
      // No key before ':': OpenCV computes a negative length and throws
      // std::length_error, not a parse error.
      {"empty_key.yaml", yaml + "x:\n  a: 1\n  : 2\n", "a key is missing", 7},
      {"base64.yaml", yaml + "x: !!binary |\n  " + spaces + "\ny: 1\n", "would never finish", 6},
      {"base64.xml",
       "<?xml version=\"1.0\"?>\n<opencv_storage>\n<x type_id=\"binary\">\n  " + spaces +
           "\n</x>\n</opencv_storage>\n",
       "would never finish", 4},
      {"base64.json", "{\"x\": \"$base64$" + spaces + "\"}\n", "would never finish", 1},
      // An element typed as a string: OpenCV reads a length it never stored
      // and throws std::length_error.
      {"string_type.xml",
       "<?xml version=\"1.0\"?>\n<opencv_storage>\n<a type_id=\"str\">x</a>\n</opencv_storage>\n",
       "OpenCV could not read it", 0},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Error error =
        expectLoadError(writeText(dir, c.name, c.text), {c.needle}, CameraFileFormat::kOpenCV);
    EXPECT_EQ(error.context().line, c.line);
  }
}

// Found by the fuzz target: OpenCV allocates a matrix's declared rows x cols
// before reading its data, so a corrupt size asked for 48 GB.
TEST(CameraIo, AHugeDeclaredMatrixSizeIsAnErrorNotAnAllocation) {
  TempDir dir("matrix_size");
  const std::string head = "%YAML:1.0\n---\nimage_width: 320\nimage_height: 240\n";
  const std::string tail = "   dt: d\n   data: [100, 0, 160, 0, 100, 120, 0, 0, 1]\n";
  for (const char* rows : {"400000000", "-3", "x3", "3.5"}) {
    SCOPED_TRACE(rows);
    const std::string text =
        head + "camera_matrix: !!opencv-matrix\n   rows: " + rows + "\n   cols: 3\n" + tail;
    expectLoadError(writeText(dir, "k.yaml", text), {"camera_matrix.rows", "from 1 to 64"},
                    CameraFileFormat::kOpenCV);
  }
  const std::string good = head + "camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n" + tail;
  EXPECT_NO_THROW(loadCamera(writeText(dir, "good.yaml", good), CameraFileFormat::kOpenCV));
}

TEST(CameraIo, RepeatedKeysAreErrors) {
  struct Case {
    std::string file;
    std::vector<std::string> needles;  // the line, the key, the first line
  };
  const std::vector<Case> cases = {
      {"lookboth_duplicate_key.yaml", {":6:", "'width'", "duplicate key (first at line 4)"}},
      {"lookboth_duplicate_param.yaml", {":11:", "'fx'", "duplicate key (first at line 7)"}},
      {"ros_duplicate_key.yaml", {":13:", "'data'", "duplicate key (first at line 12)"}},
      {"kalibr_duplicate_camera.yaml", {":7:", "'cam0'", "duplicate key (first at line 1)"}},
      {"opencv_duplicate_key.yaml",
       {":15:", "'distortion_coefficients'", "duplicate key (first at line 10)"}},
      {"opencv_duplicate_key.xml", {":11:", "'data'", "duplicate key (first at line 9)"}},
      // calib_results.txt has no keys; its header comments name the blocks.
      {"ocam_duplicate_header.txt",
       {":17:", "'center'", "duplicate block header (first at line 9)"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.file);
    expectLoadError(dataFile(c.file), c.needles);
  }
  EXPECT_THROW(loadKalibrCamchain(dataFile("kalibr_duplicate_camera.yaml")), Error);
  EXPECT_THROW(cameraFromYaml(readText(dataFile("lookboth_duplicate_key.yaml")), "string"), Error);

  TempDir dir("repeated");
  const fs::path json = writeText(dir, "repeated.json",
                                  "{\n  \"image_width\": 640,\n  \"image_height\": 480,\n"
                                  "  \"image_width\": 1280\n}\n");
  expectLoadError(json, {":4:", "'image_width'", "duplicate key (first at line 2)"},
                  CameraFileFormat::kOpenCV);
}

TEST(CameraIo, MessagesQuoteOnlyTheStartOfAHugeValue) {
  TempDir dir("huge");
  const std::string huge = repeat("x", 100000);
  struct Case {
    std::string name;
    std::string text;
    CameraFileFormat format;
    std::string needle;
  };
  const std::string ros =
      "image_width: 640\nimage_height: 480\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
      "  data: [500, 0, 319.5, 0, 500, 239.5, 0, 0, 1]\n"
      "distortion_coefficients:\n  rows: 1\n  cols: 0\n  data: []\n";
  const std::vector<Case> cases = {
      {"model.yaml",
       "lookboth_camera: 1\nmodel: " + huge +
           "\nwidth: 640\nheight: 480\nparams: {fx: 500, fy: 500, cx: 319.5, cy: 239.5}\n",
       CameraFileFormat::kAuto, "unknown camera model 'xxx"},
      {"number.yaml",
       "lookboth_camera: 1\nmodel: pinhole\nwidth: 640\nheight: 480\n"
       "params: {fx: " +
           huge + ", fy: 500, cx: 319.5, cy: 239.5}\n",
       CameraFileFormat::kAuto, "not a finite number: 'xxx"},
      // An explicit key ("? "): YAML allows no implicit key this long.
      {"key.yaml", "lookboth_camera: 1\n? " + huge + "\n: 1\n", CameraFileFormat::kAuto, "'xxx"},
      {"ros.yaml", ros + "distortion_model: " + huge + "\n", CameraFileFormat::kRosCameraInfo,
       "unsupported distortion model 'xxx"},
      {"ros_name.yaml", ros + "camera_name: " + huge + "\ndistortion_model: fisheye\n",
       CameraFileFormat::kRosCameraInfo, "[xxx"},
      {"kalibr.yaml",
       "cam0:\n  camera_model: " + huge +
           "\n  intrinsics: [500, 500, 319.5, 239.5]\n  distortion_model: none\n"
           "  resolution: [640, 480]\n",
       CameraFileFormat::kAuto, "camera model 'xxx"},
      {"ocam.txt", "#polynomial coefficients for the DIRECT mapping function\n1 " + huge + "\n",
       CameraFileFormat::kAuto, "not a number: 'xxx"},
      {"opencv.yaml",
       readText(dataFile("opencv_pinhole.yaml")) + "distortion_model: " + huge + "\n",
       CameraFileFormat::kAuto, "unknown distortion model 'xxx"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Error error = expectLoadError(writeText(dir, c.name, c.text), {c.needle}, c.format);
    const std::string what = error.what();
    EXPECT_LT(what.size(), 400u) << what.substr(0, 400);
    EXPECT_NE(what.find("..."), std::string::npos) << what.substr(0, 400);
    EXPECT_EQ(what.find(repeat("x", 61)), std::string::npos) << what.substr(0, 400);
  }
}

// ---------------------------------------------------------------------------
// MRPT TCamera

TEST(CameraIo, MrptTCameraRoundTrip) {
  for (const Camera& camera : camerasOfEveryModel()) {
    SCOPED_TRACE(camera.modelName());
    const std::string model = camera.modelName();
    if (model == "scaramuzza" || model == "double_sphere") {
      try {
        toMrptCamera(camera);
        ADD_FAILURE() << "TCamera accepted " << model;
      } catch (const Error& error) {
        EXPECT_NE(std::string(error.what()).find("TCamera cannot hold"), std::string::npos)
            << error.what();
        EXPECT_NE(std::string(error.what()).find(model), std::string::npos) << error.what();
      }
      continue;
    }
    const mrpt::img::TCamera mrpt_camera = toMrptCamera(camera);
    EXPECT_EQ(mrpt_camera.ncols, static_cast<uint32_t>(camera.width()));
    EXPECT_EQ(mrpt_camera.nrows, static_cast<uint32_t>(camera.height()));
    EXPECT_EQ(mrpt_camera.fx(), camera.params()[0]);
    EXPECT_EQ(mrpt_camera.cy(), camera.params()[3]);
    const Camera back = fromMrptCamera(mrpt_camera);
    expectParams(back, model, camera.width(), camera.height(), camera.params());
  }
  // Kannala-Brandt lives in TCamera's slots [k1 k2 . . k3 k4].
  const Camera kb = loadCamera(shareFile("fisheye_kannala_brandt.yaml"));
  const mrpt::img::TCamera kb_mrpt = toMrptCamera(kb);
  EXPECT_EQ(kb_mrpt.distortion, mrpt::img::DistortionModel::kannala_brandt);
  EXPECT_EQ(kb_mrpt.dist[4], -0.00072);
  EXPECT_EQ(kb_mrpt.dist[5], 0.000058);

  // plumb_bob with zero k4..k6 is radtan; skew is refused.
  mrpt::img::TCamera plain;
  plain.ncols = 640;
  plain.nrows = 480;
  plain.setIntrinsicParamsFromValues(500, 501, 320, 240);
  plain.setDistortionPlumbBob(-0.1, 0.01, 0.001, 0.002, 0.0);
  expectParams(fromMrptCamera(plain), "radtan", 640, 480,
               {500, 501, 320, 240, -0.1, 0.01, 0.001, 0.002, 0.0});
  plain.intrinsicParams(0, 1) = 0.5;
  EXPECT_THROW(fromMrptCamera(plain), Error);
}

}  // namespace
}  // namespace lookboth
