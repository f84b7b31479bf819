// Speed of the odometry on 1920x1080 fisheye frames at 30 Hz (the paper's
// stream): decoding a PNG frame, preparing it (grey, downscaled to the
// working width), and tracking+mapping a rendered sequence, beside the bare
// OpenCV pyramidal Lucas-Kanade tracking of the same frames (the cost floor
// of any KLT front end) as the peer. Frames are rendered once by the
// simulator (the share OCamCalib calibration, the robot driving at 1 m/s).
#include <benchmark/benchmark.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>
#include <random>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/sim/render.h"
#include "lookboth/vo/odometry.h"

namespace lookboth::vo {
namespace {

constexpr int kFrames = 90;  // 3 s at 30 Hz

struct Sequence {
  Camera camera;
  std::vector<std::vector<std::uint8_t>> png;  ///< Encoded 1920x1080 frames.
  std::vector<cv::Mat> prepared;               ///< Working resolution.
  std::vector<TimeNs> t;
};

const Sequence& sequence() {
  static const Sequence s = [] {
    Sequence seq{loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_calib_results.txt"),
                 {},
                 {},
                 {}};
    const sim::World world(sim::WorldSpec{}, 2024);
    sim::RenderOptions options;
    options.supersampling = 1;
    std::mt19937 rng(1);
    const int factor = VisualOdometry::downscaleFactor(seq.camera.width(), OdometryOptions());
    for (int i = 0; i < kFrames; ++i) {
      const double x = 10.0 + std::min(1.0, i / 15.0) * i / 30.0;  // accelerate to 1 m/s
      const Rigid3d pose(
          Eigen::Quaterniond(Eigen::AngleAxisd(0.3 + 0.002 * i, Eigen::Vector3d::UnitZ())),
          Eigen::Vector3d(x, 9.5, 0.3));
      const cv::Mat frame = sim::renderFisheye(world, seq.camera, pose, options, rng);
      std::vector<std::uint8_t> bytes;
      cv::imencode(".png", frame, bytes);
      seq.png.push_back(bytes);
      seq.prepared.push_back(VisualOdometry::prepareImage(frame, factor));
      seq.t.push_back(secondsToNs(1700000000) + static_cast<TimeNs>(i) * 33333333);
    }
    return seq;
  }();
  return s;
}

void setRate(benchmark::State& state, double frames_per_iteration) {
  state.counters["frames/s"] = benchmark::Counter(
      frames_per_iteration * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_DecodePng1080p(benchmark::State& state) {
  cv::setNumThreads(1);
  const Sequence& s = sequence();
  size_t i = 0;
  for (auto _ : state) {
    const std::vector<std::uint8_t>& b = s.png[i++ % s.png.size()];
    const cv::Mat bytes(1, static_cast<int>(b.size()), CV_8U, const_cast<std::uint8_t*>(b.data()));
    benchmark::DoNotOptimize(cv::imdecode(bytes, cv::IMREAD_GRAYSCALE).data);
  }
  setRate(state, 1);
}
BENCHMARK(BM_DecodePng1080p)->Unit(benchmark::kMillisecond);

void BM_DecodeAndPrepare1080p(benchmark::State& state) {
  cv::setNumThreads(1);
  const Sequence& s = sequence();
  const int factor = VisualOdometry::downscaleFactor(s.camera.width(), OdometryOptions());
  size_t i = 0;
  for (auto _ : state) {
    const std::vector<std::uint8_t>& b = s.png[i++ % s.png.size()];
    const cv::Mat bytes(1, static_cast<int>(b.size()), CV_8U, const_cast<std::uint8_t*>(b.data()));
    benchmark::DoNotOptimize(
        VisualOdometry::prepareImage(cv::imdecode(bytes, cv::IMREAD_GRAYSCALE), factor).data);
  }
  setRate(state, 1);
}
BENCHMARK(BM_DecodeAndPrepare1080p)->Unit(benchmark::kMillisecond);

/// Tracking and mapping of the whole sequence (fresh odometry each time).
void BM_OdometryTrackAndMap1080p(benchmark::State& state) {
  cv::setNumThreads(1);
  const Sequence& s = sequence();
  OdometryOptions options;
  options.loop_closure = state.range(0) != 0;
  for (auto _ : state) {
    VisualOdometry odometry(s.camera, options);
    for (size_t i = 0; i < s.prepared.size(); ++i) odometry.processFrame(s.t[i], s.prepared[i]);
    state.PauseTiming();
    const OdometryStatistics& st = odometry.statistics();
    state.counters["keyframes"] = static_cast<double>(st.keyframes);
    state.counters["tracked"] = static_cast<double>(st.tracked_frames);
    state.ResumeTiming();
  }
  setRate(state, kFrames);
}
BENCHMARK(BM_OdometryTrackAndMap1080p)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(3);

/// The peer: bare pyramidal Lucas-Kanade of 500 corners frame to frame, no
/// checks, no geometry, no map (what any KLT front end pays at least).
void BM_BareKlt500(benchmark::State& state) {
  cv::setNumThreads(1);
  const Sequence& s = sequence();
  for (auto _ : state) {
    std::vector<cv::Point2f> points;
    cv::goodFeaturesToTrack(s.prepared[0], points, 500, 0.01, 8);
    for (size_t i = 1; i < s.prepared.size(); ++i) {
      std::vector<cv::Point2f> next;
      std::vector<uchar> status;
      std::vector<float> err;
      cv::calcOpticalFlowPyrLK(s.prepared[i - 1], s.prepared[i], points, next, status, err,
                               cv::Size(15, 15), 3);
      points = next;
    }
  }
  setRate(state, kFrames - 1);
}
BENCHMARK(BM_BareKlt500)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace lookboth::vo

BENCHMARK_MAIN();
