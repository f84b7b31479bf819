// SceneChange (detect/pass_search.h) on a real fixed camera's video whose
// frames are labelled by hand: how far empty views differ from each other
// (the noise the threshold must stay above), how far a view with a vehicle
// differs from the empty ones (what it must stay below), and which frames the
// coarse search would leave unsearched, every frame as lookboth decodes it.
//
//   bench_scene_change <video> <labels.csv> [frame_rate_hz=30] [threshold_grey=12]
//                      [max_unchanged_s=5]
//
// labels.csv: "first,last,what" per line (frame indices, both included;
// what: empty, vehicle, or swaying: empty but the camera moving); '#' starts
// a comment. tests/data/views/bgslibrary_road/ has the labels of the video
// it names and the figures this printed.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "lookboth/core/error.h"
#include "lookboth/dataset/video.h"
#include "lookboth/detect/pass_search.h"

namespace {

using namespace lookboth;

enum class What { kUnlabelled, kEmpty, kVehicle, kSwaying };

std::vector<What> readLabels(const std::string& path, std::size_t frames) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot be read");
  std::vector<What> what(frames, What::kUnlabelled);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    line = line.substr(0, line.find('#'));
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream fields(line);
    long first = -1, last = -1;
    std::string name;
    if (!(fields >> first >> last >> name) || first < 0 || last < first ||
        last >= static_cast<long>(frames))
      throw Error(path + ":" + std::to_string(number) + ": expected first,last,what in the video");
    const What label = name == "empty"     ? What::kEmpty
                       : name == "vehicle" ? What::kVehicle
                       : name == "swaying" ? What::kSwaying
                                           : What::kUnlabelled;
    if (label == What::kUnlabelled)
      throw Error(path + ":" + std::to_string(number) + ": '" + name +
                  "' is not empty, vehicle or swaying");
    std::fill(what.begin() + first, what.begin() + last + 1, label);
  }
  return what;
}

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(p * static_cast<double>(values.size() - 1))];
}

/// The differences of every frame labelled `of` from every earlier empty frame.
std::vector<double> differencesFromEarlierEmpty(const std::vector<cv::Mat>& grey,
                                                const std::vector<What>& what, What of,
                                                double threshold, std::size_t* smallest_at) {
  std::vector<double> out;
  double smallest = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < grey.size(); ++a) {
    if (what[a] != What::kEmpty) continue;
    SceneChange view(threshold);
    view.difference(grey[a]);
    view.keep();
    for (std::size_t b = a + 1; b < grey.size(); ++b) {
      if (what[b] != of) continue;
      out.push_back(view.difference(grey[b]));
      if (out.back() < smallest) {
        smallest = out.back();
        if (smallest_at) *smallest_at = b;
      }
    }
  }
  return out;
}

/// The coarse search's use of SceneChange over frames 0, step, 2 step...:
/// each frame searched becomes the reference (the video shows no marker).
void replay(const std::vector<cv::Mat>& grey, const std::vector<What>& what, std::size_t step,
            double threshold, std::size_t max_unchanged) {
  SceneChange view(threshold);
  std::size_t searched = 0, unchanged = 0, vehicles_searched = 0, vehicles_unchanged = 0;
  std::size_t reference = 0;
  for (std::size_t i = 0; i < grey.size(); i += step) {
    const bool vehicle = what[i] == What::kVehicle;
    if (!view.changed(grey[i]) && i - reference <= max_unchanged) {
      ++unchanged;
      vehicles_unchanged += vehicle ? 1 : 0;
      continue;
    }
    ++searched;
    vehicles_searched += vehicle ? 1 : 0;
    view.keep();
    reference = i;
  }
  std::printf(
      "coarse frames every %zu: %zu, %zu searched (%zu with a vehicle), %zu unchanged "
      "(%zu with a vehicle)\n",
      step, searched + unchanged, searched, vehicles_searched, unchanged, vehicles_unchanged);
}

int run(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: bench_scene_change <video> <labels.csv> [frame_rate_hz=30] "
                 "[threshold_grey=12] [max_unchanged_s=5]\n");
    return 2;
  }
  const double rate_hz = argc > 3 ? std::atof(argv[3]) : 30.0;
  const double threshold = argc > 4 ? std::atof(argv[4]) : 12.0;
  const double max_unchanged_s = argc > 5 ? std::atof(argv[5]) : 5.0;
  if (!(rate_hz > 0)) throw Error("the frame rate must be positive");
  VideoDecoder video(argv[1]);
  std::vector<cv::Mat> grey;
  const auto start = std::chrono::steady_clock::now();
  for (cv::Mat frame;
       !(frame = video.frame(static_cast<std::int64_t>(grey.size()), false)).empty();)
    grey.push_back(frame);
  const double decode_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (grey.empty()) throw Error(std::string(argv[1]) + ": no frame decoded");
  const std::vector<What> what = readLabels(argv[2], grey.size());
  std::printf("%s: %zu frames %dx%d, decoded in %.2f ms each\n", argv[1], grey.size(), grey[0].cols,
              grey[0].rows, 1e3 * decode_s / static_cast<double>(grey.size()));

  std::vector<double> empty =
      differencesFromEarlierEmpty(grey, what, What::kEmpty, threshold, nullptr);
  std::printf("empty against empty: %zu pairs, median %.1f, 99th percentile %.1f, largest %.1f\n",
              empty.size(), percentile(empty, 0.5), percentile(empty, 0.99),
              percentile(empty, 1.0));
  const std::vector<double> swaying =
      differencesFromEarlierEmpty(grey, what, What::kSwaying, threshold, nullptr);
  if (!swaying.empty())
    std::printf("swaying against empty: %zu pairs, smallest %.1f, median %.1f, largest %.1f\n",
                swaying.size(), percentile(swaying, 0), percentile(swaying, 0.5),
                percentile(swaying, 1.0));
  std::size_t at = 0;
  const std::vector<double> vehicle =
      differencesFromEarlierEmpty(grey, what, What::kVehicle, threshold, &at);
  if (!vehicle.empty())
    std::printf(
        "vehicle against earlier empty: %zu pairs, smallest %.1f (frame %zu), median %.1f\n",
        vehicle.size(), percentile(vehicle, 0), at, percentile(vehicle, 0.5));

  // The time a comparison takes, beside the decoding of the same frames.
  SceneChange view(threshold);
  view.difference(grey[0]);
  view.keep();
  const auto compare_start = std::chrono::steady_clock::now();
  for (const cv::Mat& frame : grey) view.difference(frame);
  const double compare_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - compare_start).count();
  std::printf("a comparison: %.3f ms (%.2fx the decoding)\n",
              1e3 * compare_s / static_cast<double>(grey.size()), compare_s / decode_s);

  // Coarse frames every 1 s, every 0.2 s (the defaults' coarse_period_s) and every frame.
  const auto max_unchanged = static_cast<std::size_t>(max_unchanged_s * rate_hz);
  for (const double period_s : {1.0, 0.2, 0.0}) {
    const auto step = std::max<std::size_t>(1, static_cast<std::size_t>(period_s * rate_hz + 0.5));
    replay(grey, what, step, threshold, max_unchanged);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_scene_change: %s\n", e.what());
    return 1;
  }
}
