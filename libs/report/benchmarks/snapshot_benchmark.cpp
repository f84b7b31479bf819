// Speed of `lookboth snapshot`'s fisheye checks: 20 frames of a 1920x1080
// dataset (reading the dataset, choosing, decoding, drawing, PNG encoding,
// atomic writes), against the peer floor of any colour-overlay tool in the
// same run: OpenCV decoding the same 20 PNG frames to colour and encoding them
// again as PNG (same compression level, one thread, nothing drawn or written).
//
//   bench_report_snapshot <dataset.rawlog> [--benchmark_...]
// The registration is made from the dataset's ground truth (the timing does
// not depend on its values).
#include <benchmark/benchmark.h>

#include <filesystem>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "../tests/truth_registration.h"
#include "lookboth/report/snapshot.h"

namespace {

namespace fs = std::filesystem;
fs::path g_dataset;
constexpr int kFrames = 20;

lookboth::report::FrameSelection firstFrames() {
  lookboth::report::FrameSelection selection;
  selection.mode = lookboth::report::FrameSelection::Mode::kIndices;
  for (int i = 0; i < kFrames; ++i) selection.indices.push_back(i);
  return selection;
}

void BM_SnapshotFisheyeChecks(benchmark::State& state) {
  using namespace lookboth::report;
  const RegistrationView view = viewOfRegistration(
      testing::registrationFromTruth(g_dataset, Eigen::Vector3d(0.1, -0.05, 0.05)), "truth");
  SnapshotOptions options;
  options.out = fs::temp_directory_path() / "lookboth_bench_snapshot";
  options.frames = firstFrames();
  options.overview = false;
  options.max_env_views = 0;
  for (auto _ : state) {
    const SnapshotResult result =
        writeSnapshots(g_dataset, view, options, lookboth::ProgressReporter());
    if (result.pictures.size() != kFrames) state.SkipWithError("not 20 pictures");
  }
  fs::remove_all(options.out);
  state.counters["frames"] = kFrames;
}

void BM_PeerOpenCvDecodeEncode(benchmark::State& state) {
  std::vector<fs::path> files;
  auto reader = lookboth::DatasetReader::open(g_dataset);
  const std::string fisheye = reader->manifest().fisheye()->label;
  while (auto record = reader->next()) {
    const auto* frame = std::get_if<lookboth::ImageFrame>(&*record);
    if (frame && frame->sensor == fisheye && files.size() < kFrames)
      files.push_back(frame->image_file);
  }
  for (auto _ : state) {
    for (const fs::path& file : files) {
      const cv::Mat image = cv::imread(file.string(), cv::IMREAD_COLOR);  // grey -> BGR
      std::vector<std::uint8_t> bytes;
      cv::imencode(".png", image, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1});
      benchmark::DoNotOptimize(bytes.data());
    }
  }
  state.counters["frames"] = static_cast<double>(files.size());
}

BENCHMARK(BM_SnapshotFisheyeChecks)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PeerOpenCvDecodeEncode)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (argc != 2) {
    std::cerr << "usage: " << argv[0] << " <dataset with >= 20 fisheye frames> [--benchmark_...]\n";
    return 2;
  }
  g_dataset = argv[1];
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
