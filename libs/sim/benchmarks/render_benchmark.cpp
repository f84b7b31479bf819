// Render throughput at 1920x1080: the upward fisheye (the share OCamCalib
// calibration), an environment camera with the robot in view, whole or
// from its static view (a full recording's frames), and, as the
// cost floor of any per-pixel warp, a plain cv::remap with a precomputed map.
#include <benchmark/benchmark.h>

#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/sim/render.h"

namespace lookboth::sim {
namespace {

Camera shareCamera(const char* name) {
  return loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/" + name);
}

World benchmarkWorld() {
  World world(WorldSpec{}, 2024);
  for (double x = 4.0; x < 40.0; x += 6.0) {
    for (double y = 3.0; y < 20.0; y += 6.0) {
      world.addHousing({"cam", {x, y, world.ceilingHeightAt(x, y) - 0.12}, 0.06, 0.12, 0.02});
    }
  }
  return world;
}

/// The share's 1920x1080 ceiling camera 3.5 m up, looking straight down.
struct DownCamera {
  Camera camera = shareCamera("ceiling_camera_ros.yaml");
  Rigid3d world_from_camera{
      Eigen::Quaterniond(Eigen::Matrix3d(Eigen::Vector3d(1, -1, -1).asDiagonal())),
      Eigen::Vector3d(20.0, 10.0, 3.5)};
};

/// The robot at x along the camera's row.
RobotAppearance robotAt(double x) {
  RobotAppearance robot;
  robot.world_from_base = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, 10.3, 0.0));
  robot.world_from_marker = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(x, 10.3, 0.25));
  return robot;
}

void setRate(benchmark::State& state) {
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_RenderFisheye1080p(benchmark::State& state) {
  const Camera fisheye = shareCamera("fisheye_calib_results.txt");
  const World world = benchmarkWorld();
  RenderOptions options;
  options.supersampling = static_cast<int>(state.range(0));
  std::mt19937 rng(1);
  renderFisheye(world, fisheye, Rigid3d(), options, rng);  // builds the camera's bearing table
  double x = 17.0;
  for (auto _ : state) {
    const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ())),
                       Eigen::Vector3d(x, 9.5, 0.3));
    benchmark::DoNotOptimize(renderFisheye(world, fisheye, pose, options, rng).data);
    x += 0.03;
  }
  setRate(state);
}
BENCHMARK(BM_RenderFisheye1080p)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_RenderEnvCamera1080p(benchmark::State& state) {
  const DownCamera down;
  const World world = benchmarkWorld();
  RenderOptions options;
  options.supersampling = static_cast<int>(state.range(0));
  std::mt19937 rng(1);
  double x = 19.0;
  // Builds the camera's bearing table.
  renderEnvCamera(world, down.camera, down.world_from_camera, RobotAppearance(), options, rng);
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        renderEnvCamera(world, down.camera, down.world_from_camera, robotAt(x), options, rng).data);
    x += 0.03;
  }
  setRate(state);
}
BENCHMARK(BM_RenderEnvCamera1080p)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

/// A full recording's frame made from the camera's static view: the robot
/// in view (arg 1: its box cast again) or away (arg 0: exposure, blur and
/// noise only), supersampling 2.
void BM_RenderEnvCameraFromBackground1080p(benchmark::State& state) {
  const DownCamera down;
  const World world = benchmarkWorld();
  RenderOptions options;
  const EnvBackground background =
      renderEnvBackground(world, down.camera, down.world_from_camera, options);
  std::mt19937 rng(1);
  double x = state.range(0) ? 19.0 : 35.0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(renderEnvCamera(world, down.camera, down.world_from_camera, robotAt(x),
                                             options, rng, &background)
                                 .data);
    x += 0.03;
  }
  setRate(state);
}
BENCHMARK(BM_RenderEnvCameraFromBackground1080p)
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

/// The floor: one bilinear lookup per pixel through a precomputed map (here
/// the fisheye's pixels -> a pinhole view), no ray casting at all.
void BM_RemapFloor1080p(benchmark::State& state) {
  const int w = 1920, h = 1080;
  cv::Mat source(h, w, CV_8UC1);
  cv::randu(source, 0, 256);
  cv::Mat map_x(h, w, CV_32FC1), map_y(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const double du = u - 0.5 * w, dv = v - 0.5 * h, r = std::hypot(du, dv) / w;
      map_x.at<float>(v, u) = static_cast<float>(0.5 * w + du * (1.0 - 0.3 * r * r));
      map_y.at<float>(v, u) = static_cast<float>(0.5 * h + dv * (1.0 - 0.3 * r * r));
    }
  }
  cv::Mat out;
  for (auto _ : state) {
    cv::remap(source, out, map_x, map_y, cv::INTER_LINEAR);
    benchmark::DoNotOptimize(out.data);
  }
  setRate(state);
}
BENCHMARK(BM_RemapFloor1080p)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace lookboth::sim

BENCHMARK_MAIN();
