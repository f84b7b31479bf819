// lookboth's camera models against OpenCV on the same 10k points: projection
// (radtan vs cv::projectPoints, Kannala-Brandt vs cv::fisheye::projectPoints)
// and unprojection (vs cv::undistortPoints, cv::fisheye::undistortPoints).
// Counters: points/s, and for unprojection max_err_px, the largest distance
// between a pixel and the projection of the ray it was unprojected to.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/cameras/camera_io.h"

namespace lookboth {
namespace {

constexpr int kPoints = 10000;

/// A camera, points in front of it whose pixels fall inside the image, and
/// the same data in OpenCV's types.
struct Scene {
  Camera camera;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  std::vector<cv::Point3d> cv_points;
  std::vector<cv::Point2d> cv_pixels;
  cv::Matx33d camera_matrix;
  std::vector<double> distortion;  // the parameters after fx fy cx cy
};

Scene makeScene(Camera camera, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.5, camera.width() - 0.5);
  std::uniform_real_distribution<double> v(-0.5, camera.height() - 0.5);
  std::uniform_real_distribution<double> depth(1.0, 10.0);
  const std::vector<double>& p = camera.params();
  Scene scene{camera,
              {},
              {},
              {},
              {},
              cv::Matx33d(p[0], 0.0, p[2], 0.0, p[1], p[3], 0.0, 0.0, 1.0),
              std::vector<double>(p.begin() + 4, p.end())};
  while (scene.points.size() < static_cast<std::size_t>(kPoints)) {
    const double y = v(rng);
    const auto bearing = camera.unproject(Eigen::Vector2d(u(rng), y));
    if (!bearing || bearing->z() < 0.1) continue;  // OpenCV needs z > 0
    const Eigen::Vector3d point = *bearing * depth(rng);
    const Eigen::Vector2d pixel = *camera.project(point);
    scene.points.push_back(point);
    scene.pixels.push_back(pixel);
    scene.cv_points.emplace_back(point.x(), point.y(), point.z());
    scene.cv_pixels.emplace_back(pixel.x(), pixel.y());
  }
  return scene;
}

const Scene& radtanScene() {
  static const Scene scene = makeScene(
      Camera(RadTanModel{}, 1280, 720, {700.0, 701.0, 640.2, 359.7, -0.28, 0.07, 1e-4, -2e-4, 0.0}),
      1);
  return scene;
}

const Scene& kannalaBrandtScene() {
  static const Scene scene =
      makeScene(Camera(KannalaBrandtModel{}, 1920, 1080,
                       {540.0, 540.5, 959.5, 539.5, 0.02, -3e-3, 5e-4, -1e-4}),
                2);
  return scene;
}

/// The shipped OCamCalib fisheye (share/lookboth/cameras): its projection
/// solves for the sensor radius numerically (no closed form; OpenCV has no
/// such model, so the Kannala-Brandt projection above is the yardstick).
const Scene& scaramuzzaScene() {
  static const Scene scene = makeScene(
      loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_calib_results.txt"), 3);
  return scene;
}

/// The same lens with its direct polynomial only, as the simulator writes it
/// (and as many calibrations come): no inverse polynomial to seed the solve.
const Scene& scaramuzzaDirectOnlyScene() {
  static const Scene scene = [] {
    const Camera full =
        loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_calib_results.txt");
    const auto* model = std::get_if<ScaramuzzaModel>(&full.model());
    ScaramuzzaModel direct = *model;
    direct.num_inv_poly = 0;
    std::vector<double> params(full.params().begin(), full.params().begin() + 5 + direct.num_poly);
    return makeScene(Camera(direct, full.width(), full.height(), params), 4);
  }();
  return scene;
}

/// Mei's unified model at 1280x1024 (xi 1.5, a fisheye of about 190 deg).
const Scene& meiScene() {
  static const Scene scene = makeScene(
      Camera(MeiModel{}, 1280, 1024, {750.0, 750.5, 639.5, 511.5, 1.5, -0.05, 0.01, 2e-4, -1e-4}),
      5);
  return scene;
}

void setRate(benchmark::State& state) {
  state.counters["points/s"] = benchmark::Counter(static_cast<double>(kPoints),
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

/// Largest pixel distance between `scene.pixels` and the projections of the
/// normalized coordinates (x/z, y/z) OpenCV returned for them.
double maxErrorOfNormalized(const Scene& scene, const std::vector<cv::Point2d>& normalized) {
  double worst = 0.0;
  for (std::size_t i = 0; i < normalized.size(); ++i) {
    const auto pixel = scene.camera.project(Eigen::Vector3d(normalized[i].x, normalized[i].y, 1.0));
    worst = std::max(worst, pixel ? (*pixel - scene.pixels[i]).norm() : 1e9);
  }
  return worst;
}

double maxErrorOfLookboth(const Scene& scene) {
  double worst = 0.0;
  for (const Eigen::Vector2d& pixel : scene.pixels) {
    const auto bearing = scene.camera.unproject(pixel);
    const auto back = bearing ? scene.camera.project(*bearing) : std::nullopt;
    worst = std::max(worst, back ? (*back - pixel).norm() : 1e9);
  }
  return worst;
}

void projectLookboth(benchmark::State& state, const Scene& scene) {
  for (auto _ : state) {
    for (const Eigen::Vector3d& point : scene.points) {
      auto pixel = scene.camera.project(point);
      benchmark::DoNotOptimize(pixel);
    }
  }
  setRate(state);
}

void unprojectLookboth(benchmark::State& state, const Scene& scene) {
  for (auto _ : state) {
    for (const Eigen::Vector2d& pixel : scene.pixels) {
      auto bearing = scene.camera.unproject(pixel);
      benchmark::DoNotOptimize(bearing);
    }
  }
  setRate(state);
  state.counters["max_err_px"] = maxErrorOfLookboth(scene);
}

void BM_RadTanProject_Lookboth(benchmark::State& state) { projectLookboth(state, radtanScene()); }

void BM_RadTanProject_OpenCV(benchmark::State& state) {
  const Scene& scene = radtanScene();
  std::vector<cv::Point2d> pixels;
  for (auto _ : state) {
    cv::projectPoints(scene.cv_points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), scene.camera_matrix,
                      scene.distortion, pixels);
    benchmark::DoNotOptimize(pixels.data());
  }
  setRate(state);
}

void BM_KannalaBrandtProject_Lookboth(benchmark::State& state) {
  projectLookboth(state, kannalaBrandtScene());
}

void BM_KannalaBrandtProject_OpenCV(benchmark::State& state) {
  const Scene& scene = kannalaBrandtScene();
  std::vector<cv::Point2d> pixels;
  for (auto _ : state) {
    cv::fisheye::projectPoints(scene.cv_points, pixels, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                               scene.camera_matrix, scene.distortion);
    benchmark::DoNotOptimize(pixels.data());
  }
  setRate(state);
}

void BM_ScaramuzzaProject_Lookboth(benchmark::State& state) {
  projectLookboth(state, scaramuzzaScene());
}

void BM_ScaramuzzaDirectOnlyProject_Lookboth(benchmark::State& state) {
  projectLookboth(state, scaramuzzaDirectOnlyScene());
}

void BM_RadTanUnproject_Lookboth(benchmark::State& state) {
  unprojectLookboth(state, radtanScene());
}

void BM_RadTanUnproject_OpenCV(benchmark::State& state) {
  const Scene& scene = radtanScene();
  std::vector<cv::Point2d> normalized;
  for (auto _ : state) {
    cv::undistortPoints(scene.cv_pixels, normalized, scene.camera_matrix, scene.distortion);
    benchmark::DoNotOptimize(normalized.data());
  }
  setRate(state);
  state.counters["max_err_px"] = maxErrorOfNormalized(scene, normalized);
}

void BM_KannalaBrandtUnproject_Lookboth(benchmark::State& state) {
  unprojectLookboth(state, kannalaBrandtScene());
}

void BM_KannalaBrandtUnproject_OpenCV(benchmark::State& state) {
  const Scene& scene = kannalaBrandtScene();
  std::vector<cv::Point2d> normalized;
  for (auto _ : state) {
    cv::fisheye::undistortPoints(scene.cv_pixels, normalized, scene.camera_matrix,
                                 scene.distortion);
    benchmark::DoNotOptimize(normalized.data());
  }
  setRate(state);
  state.counters["max_err_px"] = maxErrorOfNormalized(scene, normalized);
}

void BM_MeiProject_Lookboth(benchmark::State& state) { projectLookboth(state, meiScene()); }

void BM_MeiProject_OpenCV(benchmark::State& state) {
  const Scene& scene = meiScene();
  const std::vector<double>& p = scene.camera.params();
  std::vector<cv::Point2d> pixels;
  for (auto _ : state) {
    cv::omnidir::projectPoints(scene.cv_points, pixels, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                               scene.camera_matrix, p[4], cv::Vec4d(p[5], p[6], p[7], p[8]));
    benchmark::DoNotOptimize(pixels.data());
  }
  setRate(state);
}

void BM_MeiUnproject_Lookboth(benchmark::State& state) { unprojectLookboth(state, meiScene()); }

BENCHMARK(BM_RadTanProject_Lookboth);
BENCHMARK(BM_RadTanProject_OpenCV);
BENCHMARK(BM_KannalaBrandtProject_Lookboth);
BENCHMARK(BM_KannalaBrandtProject_OpenCV);
BENCHMARK(BM_ScaramuzzaProject_Lookboth);
BENCHMARK(BM_ScaramuzzaDirectOnlyProject_Lookboth);
BENCHMARK(BM_RadTanUnproject_Lookboth);
BENCHMARK(BM_RadTanUnproject_OpenCV);
BENCHMARK(BM_KannalaBrandtUnproject_Lookboth);
BENCHMARK(BM_KannalaBrandtUnproject_OpenCV);
BENCHMARK(BM_MeiProject_Lookboth);
BENCHMARK(BM_MeiProject_OpenCV);
BENCHMARK(BM_MeiUnproject_Lookboth);

}  // namespace
}  // namespace lookboth

BENCHMARK_MAIN();
