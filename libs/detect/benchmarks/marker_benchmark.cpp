// lookboth's marker detector against plain OpenCV on the same frames, in one
// run: full-frame cv::aruco::detectMarkers (CORNER_REFINE_SUBPIX) +
// cv::aruco::estimatePoseSingleMarkers (OpenCV's defaults) with the
// calibration's radtan coefficients, versus MarkerDetector (candidates on a region of interest
// or a reduced frame, edges fitted at full resolution, IPPE + Gauss-Newton).
//
//   bench_detect_markers <dataset.rawlog> [max_frames=240] [benchmark flags]
//   LOOKBOTH_PLAIN_REFINEMENT=none|subpix|apriltag   the peer's corner refinement (subpix)
//   LOOKBOTH_PLAIN_POSE=estimate|solvepnp|estimate_ippe  the peer's pose (estimate:
//     estimatePoseSingleMarkers with OpenCV's defaults; OpenCV 4.6's estimatePoseSingleMarkers
//     with IPPE_SQUARE gives tilts ~28 deg off on these frames: doc/benchmarks.md)
//
// Frames of the environment cameras are decoded once (not timed), in time
// order per camera, up to max_frames spread over the whole recording. Both
// pipelines see the same frames in the same order; each detector keeps its
// per-camera state (our region-of-interest track) as it would in
// `lookboth detect`. Recall and accuracy against the dataset's ground truth
// are printed for both.
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <opencv2/aruco.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "lookboth/core/error.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/dataset/marker_dictionary.h"
#include "lookboth/detect/detection_evaluation.h"
#include "lookboth/detect/marker_detector.h"

namespace {

using namespace lookboth;

struct Frame {
  std::string camera;
  TimeNs t = 0;
  cv::Mat grey;
};

struct Data {
  GroundTruthView truth;
  std::vector<Frame> frames;  ///< Grouped by camera, time order within.
};

Data* g_data = nullptr;
/// The peer's pose: "estimate" (cv::aruco::estimatePoseSingleMarkers with
/// its defaults: SOLVEPNP_ITERATIVE; the default here), "solvepnp"
/// (cv::solvePnP, IPPE_SQUARE) or "estimate_ippe" (estimatePoseSingleMarkers
/// with IPPE_SQUARE).
std::string g_pose_method = "estimate";

Data load(const std::string& path, size_t max_frames) {
  Data data;
  data.truth = loadGroundTruth(path);
  auto reader = DatasetReader::open(path);
  std::vector<ImageFrame> all;
  while (auto record = reader->next()) {
    if (const auto* f = std::get_if<ImageFrame>(&*record)) {
      const CameraSensor* sensor = reader->manifest().findCamera(f->sensor);
      if (sensor && sensor->role == SensorRole::kEnvCamera) all.push_back(*f);
    }
  }
  // Every k-th frame per camera, so that tracks keep their time order.
  const size_t stride = std::max<size_t>(1, all.size() / std::max<size_t>(1, max_frames));
  std::map<std::string, std::vector<const ImageFrame*>> by_camera;
  for (size_t i = 0; i < all.size(); i += stride) by_camera[all[i].sensor].push_back(&all[i]);
  for (auto& [camera, list] : by_camera) {
    std::sort(list.begin(), list.end(),
              [](const ImageFrame* a, const ImageFrame* b) { return a->t < b->t; });
    for (const ImageFrame* f : list) {
      cv::Mat grey = cv::imread(f->image_file.string(), cv::IMREAD_GRAYSCALE);
      if (grey.empty()) throw Error({f->image_file.string(), 0, "", camera}, "cannot decode");
      data.frames.push_back({camera, f->t, std::move(grey)});
    }
  }
  return data;
}

/// Plain OpenCV on one frame: the observation of the manifest's marker, if found.
std::optional<MarkerObservation> plainOpenCv(const Frame& frame, const Camera& camera,
                                             const MarkerSpec& marker,
                                             const cv::Ptr<cv::aruco::Dictionary>& dictionary,
                                             const cv::Ptr<cv::aruco::DetectorParameters>& params) {
  const std::vector<double>& p = camera.params();  // radtan: fx fy cx cy k1 k2 p1 p2 k3
  const cv::Matx33d K(p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
  const std::vector<double> distortion = {p[4], p[5], p[6], p[7], p[8]};
  std::vector<std::vector<cv::Point2f>> corners, rejected;
  std::vector<int> ids;
  cv::aruco::detectMarkers(frame.grey, dictionary, corners, ids, params, rejected);
  for (size_t i = 0; i < ids.size(); ++i) {
    if (ids[i] != marker.id) continue;
    std::vector<cv::Vec3d> rvecs, tvecs;
    if (g_pose_method == "solvepnp") {
      const float h = static_cast<float>(marker.size_m / 2);
      const std::vector<cv::Point3f> object = {cv::Point3f(-h, h, 0), cv::Point3f(h, h, 0),
                                               cv::Point3f(h, -h, 0), cv::Point3f(-h, -h, 0)};
      cv::Vec3d rvec, tvec;
      cv::solvePnP(object, corners[i], K, distortion, rvec, tvec, false, cv::SOLVEPNP_IPPE_SQUARE);
      rvecs.push_back(rvec);
      tvecs.push_back(tvec);
    } else {
      auto estimate = cv::aruco::EstimateParameters::create();
      if (g_pose_method == "estimate_ippe") estimate->solvePnPMethod = cv::SOLVEPNP_IPPE_SQUARE;
      cv::aruco::estimatePoseSingleMarkers(std::vector<std::vector<cv::Point2f>>{corners[i]},
                                           static_cast<float>(marker.size_m), K, distortion, rvecs,
                                           tvecs, cv::noArray(), estimate);
    }
    cv::Matx33d r;
    cv::Rodrigues(rvecs[0], r);
    Eigen::Matrix3d rotation;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) rotation(a, b) = r(a, b);
    MarkerObservation obs;
    obs.t = frame.t;
    obs.camera = frame.camera;
    obs.marker_id = ids[i];
    obs.camera_from_marker = Rigid3d(Eigen::Quaterniond(rotation).normalized(),
                                     Eigen::Vector3d(tvecs[0][0], tvecs[0][1], tvecs[0][2]));
    return obs;
  }
  return std::nullopt;
}

std::vector<MarkerObservation> runPlain(const Data& data) {
  const Manifest& manifest = data.truth.manifest;
  const auto dictionary =
      cv::aruco::getPredefinedDictionary(arucoDictionaryId(manifest.marker.dictionary));
  auto params = cv::aruco::DetectorParameters::create();
  // OpenCV's refinement of the peer: subpix (default here), none or apriltag
  // (environment variable LOOKBOTH_PLAIN_REFINEMENT).
  const char* refinement = std::getenv("LOOKBOTH_PLAIN_REFINEMENT");
  const std::string method = refinement ? refinement : "subpix";
  params->cornerRefinementMethod = method == "none"       ? cv::aruco::CORNER_REFINE_NONE
                                   : method == "apriltag" ? cv::aruco::CORNER_REFINE_APRILTAG
                                                          : cv::aruco::CORNER_REFINE_SUBPIX;
  std::vector<MarkerObservation> out;
  for (const Frame& f : data.frames) {
    const auto obs =
        plainOpenCv(f, *manifest.findCamera(f.camera)->camera, manifest.marker, dictionary, params);
    if (obs) out.push_back(*obs);
  }
  return out;
}

std::vector<MarkerObservation> runOurs(const Data& data) {
  const Manifest& manifest = data.truth.manifest;
  std::map<std::string, MarkerDetector> detectors;
  std::map<std::string, std::vector<MarkerDetection*>> tracks;
  std::vector<std::pair<const Frame*, MarkerDetection>> found;
  found.reserve(data.frames.size());
  for (const Frame& f : data.frames) {
    auto it = detectors.find(f.camera);
    if (it == detectors.end()) {
      it = detectors
               .emplace(f.camera,
                        MarkerDetector(manifest.marker, *manifest.findCamera(f.camera)->camera))
               .first;
    }
    for (MarkerDetection& d : it->second.detect(f.grey)) found.emplace_back(&f, std::move(d));
  }
  for (auto& [frame, d] : found) tracks[frame->camera].push_back(&d);
  for (auto& [camera, track] : tracks) resolveAmbiguity(track);
  std::vector<MarkerObservation> out;
  for (const auto& [frame, d] : found)
    out.push_back(toMarkerObservation(d, frame->t, frame->camera));
  return out;
}

void report(const char* name, const std::vector<MarkerObservation>& observations) {
  std::vector<std::pair<std::string, TimeNs>> frames;
  for (const Frame& f : g_data->frames) frames.emplace_back(f.camera, f.t);
  const MarkerEvaluation e =
      evaluateMarkers(g_data->truth, observations, frames, {0.0, 3.0, 3.5, 4.0, 100.0});
  const MarkerErrorBand& all = e.bands.back();
  std::printf(
      "%-34s recall %d/%d, false positives %d, position error median %.2f mm, p90 %.2f "
      "mm, in-plane median %.3f deg, tilt median %.3f deg\n",
      name, e.detected_frames, e.visible_frames, e.false_positives, all.median_position_mm,
      all.p90_position_mm, all.median_in_plane_deg, all.median_tilt_deg);
}

void BM_PlainOpenCvFullFrame(benchmark::State& state) {
  std::size_t found = 0;
  for (auto _ : state) {
    const auto out = runPlain(*g_data);
    found = out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["frames_per_s"] = benchmark::Counter(
      static_cast<double>(g_data->frames.size() * state.iterations()), benchmark::Counter::kIsRate);
  state.counters["detections"] = static_cast<double>(found);
}

void BM_LookbothMarkerDetector(benchmark::State& state) {
  std::size_t found = 0;
  for (auto _ : state) {
    const auto out = runOurs(*g_data);
    found = out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["frames_per_s"] = benchmark::Counter(
      static_cast<double>(g_data->frames.size() * state.iterations()), benchmark::Counter::kIsRate);
  state.counters["detections"] = static_cast<double>(found);
}

BENCHMARK(BM_PlainOpenCvFullFrame)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_LookbothMarkerDetector)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argv[1][0] == '-') {
    std::fprintf(stderr, "usage: %s <dataset.rawlog> [max_frames=240] [benchmark flags]\n",
                 argv[0]);
    return 2;
  }
  size_t max_frames = 240;
  int consumed = 2;
  if (argc > 2 && argv[2][0] != '-') {
    max_frames = static_cast<size_t>(std::stoul(argv[2]));
    consumed = 3;
  }
  // One thread for both (OpenCV's detectMarkers would otherwise spread its
  // thresholding over a pool whose time Google Benchmark's CPU clock misses);
  // `lookboth detect` parallelises over cameras instead.
  cv::setNumThreads(1);
  if (const char* pose = std::getenv("LOOKBOTH_PLAIN_POSE")) g_pose_method = pose;
  try {
    static Data data = load(argv[1], max_frames);
    g_data = &data;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  std::printf("%zu environment-camera frames of %s (%dx%d)\n", g_data->frames.size(), argv[1],
              g_data->frames.empty() ? 0 : g_data->frames.front().grey.cols,
              g_data->frames.empty() ? 0 : g_data->frames.front().grey.rows);
  const char* refinement = std::getenv("LOOKBOTH_PLAIN_REFINEMENT");
  const std::string plain = std::string("plain OpenCV (full frame, ") +
                            (refinement ? refinement : "subpix") + ", " + g_pose_method + "):";
  report(plain.c_str(), runPlain(*g_data));
  report("lookboth MarkerDetector:", runOurs(*g_data));
  std::vector<char*> args = {argv[0]};
  for (int i = consumed; i < argc; ++i) args.push_back(argv[i]);
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
