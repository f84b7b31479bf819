// SceneChange (detect/pass_search.h) on a real fixed camera's video whose
// frames are labelled by hand: how far empty views differ from each other
// (the noise the threshold must stay above), how far a view with a vehicle
// differs from the empty ones (what it must stay below), and which coarse
// frames the search would leave unsearched, every frame as lookboth decodes it.
//
//   bench_scene_change <video> <labels.csv> [threshold_grey=12] [max_unchanged_s=5]
//
// labels.csv: one "first,last,what" line per run of frames (indices, both
// included; what: empty, vehicle, or swaying: empty but the camera moving);
// every frame labelled once; '#' starts a comment.
// tests/data/views/bgslibrary_road/ has the labels of the video it names and
// the figures this printed.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "lookboth/core/error.h"
#include "lookboth/dataset/video.h"
#include "lookboth/detect/detection_evaluation.h"
#include "lookboth/detect/pass_search.h"

namespace {

using namespace lookboth;

enum class What { kUnlabelled, kEmpty, kVehicle, kSwaying };

What parseWhat(const std::string& name) {
  if (name == "empty") return What::kEmpty;
  if (name == "vehicle") return What::kVehicle;
  if (name == "swaying") return What::kSwaying;
  return What::kUnlabelled;
}

/// Every frame's label; throws naming the file and line of a malformed or
/// overlapping range, or the first frame left without a label.
std::vector<What> readLabels(const std::string& path, std::size_t frames) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot be read");
  std::vector<What> what(frames, What::kUnlabelled);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    line = line.substr(0, line.find('#'));
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = path + ":" + std::to_string(number) + ": ";
    std::vector<std::string> fields;
    std::istringstream split(line);
    for (std::string field; std::getline(split, field, ',');) fields.push_back(field);
    long first = -1, last = -1;
    std::string name;
    if (fields.size() != 3 || !(std::istringstream(fields[0]) >> first) ||
        !(std::istringstream(fields[1]) >> last) || !(std::istringstream(fields[2]) >> name))
      throw Error(where + "expected first,last,what");
    if (first < 0 || last < first || last >= static_cast<long>(frames))
      throw Error(where + "frames " + fields[0] + "-" + fields[1] + " are not in the video's " +
                  std::to_string(frames));
    const What label = parseWhat(name);
    if (label == What::kUnlabelled)
      throw Error(where + "'" + name + "' is not empty, vehicle or swaying");
    for (long i = first; i <= last; ++i) {
      if (what[i] != What::kUnlabelled)
        throw Error(where + "frame " + std::to_string(i) + " is labelled twice");
      what[i] = label;
    }
  }
  const auto unlabelled = std::find(what.begin(), what.end(), What::kUnlabelled);
  if (unlabelled != what.end())
    throw Error(path + ": frame " + std::to_string(unlabelled - what.begin()) + " has no label");
  return what;
}

/// A command-line number >= 0; throws naming the argument otherwise.
double number(const char* text, const char* what) {
  std::size_t used = 0;
  double value = std::numeric_limits<double>::quiet_NaN();
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
  }
  if (!(value >= 0) || text[used] != '\0')
    throw Error(std::string(what) + ": '" + text + "' is not a number >= 0");
  return value;
}

/// The differences of every frame labelled `of` from every earlier empty
/// frame; `smallest_at`, when given, the frame of the smallest.
std::vector<double> differencesFromEarlierEmpty(const std::vector<cv::Mat>& grey,
                                                const std::vector<What>& what, What of,
                                                std::size_t* smallest_at = nullptr) {
  std::vector<double> out;
  double smallest = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < grey.size(); ++a) {
    if (what[a] != What::kEmpty) continue;
    SceneChange view(1.0);  // difference() does not use the threshold
    view.difference(grey[a]);
    view.keep();
    for (std::size_t b = a + 1; b < grey.size(); ++b) {
      if (what[b] != of) continue;
      out.push_back(view.difference(grey[b]));
      if (smallest_at && out.back() < smallest) {
        smallest = out.back();
        *smallest_at = b;
      }
    }
  }
  return out;
}

void printDifferences(const std::vector<cv::Mat>& grey, const std::vector<What>& what) {
  const std::vector<double> empty = differencesFromEarlierEmpty(grey, what, What::kEmpty);
  std::printf("empty against empty: %zu pairs, median %.1f, 99th percentile %.1f, largest %.1f\n",
              empty.size(), quantileOf(empty, 0.5), quantileOf(empty, 0.99), quantileOf(empty, 1));
  const std::vector<double> swaying = differencesFromEarlierEmpty(grey, what, What::kSwaying);
  if (!swaying.empty())
    std::printf("swaying against empty: %zu pairs, smallest %.1f, median %.1f, largest %.1f\n",
                swaying.size(), quantileOf(swaying, 0), quantileOf(swaying, 0.5),
                quantileOf(swaying, 1));
  std::size_t at = 0;
  const std::vector<double> vehicle = differencesFromEarlierEmpty(grey, what, What::kVehicle, &at);
  if (!vehicle.empty())
    std::printf(
        "vehicle against earlier empty: %zu pairs, smallest %.1f (frame %zu), median %.1f\n",
        vehicle.size(), quantileOf(vehicle, 0), at, quantileOf(vehicle, 0.5));
}

/// The search's coarse frames of an image sequence (PassSearch: every
/// step-th and the last) compared as detect's marker job compares them: a
/// frame unchanged since the last one searched, and within max_unchanged of
/// it, is not searched. No frame shows the marker, so there is no walk and
/// every frame searched becomes the reference.
void replay(const std::vector<cv::Mat>& grey, const std::vector<TimeNs>& times,
            const std::vector<What>& what, double period_s, double threshold,
            double max_unchanged_s) {
  const std::size_t step = coarseStep(times, period_s);
  SceneChange view(step > 1 ? threshold : 0.0);
  const auto max_unchanged_ns = static_cast<TimeNs>(max_unchanged_s * 1e9);
  TimeNs reference_t = 0;
  std::size_t searched = 0, unchanged = 0, vehicles_searched = 0, vehicles_unchanged = 0;
  PassSearch search(grey.size(), step);
  const std::atomic<bool> stop{false};
  search.run(
      [&](std::size_t i, bool) {
        const bool vehicle = what[i] == What::kVehicle;
        if (!view.changed(grey[i]) && times[i] - reference_t <= max_unchanged_ns) {
          ++unchanged;
          vehicles_unchanged += vehicle ? 1 : 0;
          return false;
        }
        ++searched;
        vehicles_searched += vehicle ? 1 : 0;
        view.keep();
        reference_t = times[i];
        return false;
      },
      stop);
  std::printf(
      "coarse frames every %.1f s (%zu frames): %zu, %zu searched (%zu with a vehicle), %zu "
      "unchanged (%zu with a vehicle)\n",
      period_s, step, searched + unchanged, searched, vehicles_searched, unchanged,
      vehicles_unchanged);
}

int run(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: bench_scene_change <video> <labels.csv> [threshold_grey=12] "
                 "[max_unchanged_s=5]\n");
    return 2;
  }
  const double threshold = argc > 3 ? number(argv[3], "threshold_grey") : 12.0;
  const double max_unchanged_s = argc > 4 ? number(argv[4], "max_unchanged_s") : 5.0;
  const VideoProbe probe = probeVideo(argv[1], true);
  if (probe.frame_offsets_ns.empty()) throw Error(std::string(argv[1]) + ": no frame times");
  const std::vector<What> what = readLabels(argv[2], probe.frame_offsets_ns.size());
  VideoDecoder video(argv[1]);
  std::vector<cv::Mat> grey;
  const auto start = std::chrono::steady_clock::now();
  for (std::size_t i = 0; i < what.size(); ++i) {
    grey.push_back(video.frame(static_cast<std::int64_t>(i), false));
    if (grey.back().empty())
      throw Error(std::string(argv[1]) + ": frame " + std::to_string(i) + " cannot be decoded");
  }
  const double decode_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("%s: %zu frames %dx%d, decoded in %.2f ms each\n", argv[1], grey.size(), grey[0].cols,
              grey[0].rows, 1e3 * decode_s / static_cast<double>(grey.size()));
  printDifferences(grey, what);

  // The time a comparison takes, beside the decoding of the same frames.
  SceneChange view(threshold);
  view.difference(grey[0]);
  view.keep();
  const auto compare_start = std::chrono::steady_clock::now();
  for (const cv::Mat& frame : grey) view.difference(frame);
  const double compare_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - compare_start).count();
  std::printf("a comparison: %.3f ms (%.2fx decoding the frame)\n",
              1e3 * compare_s / static_cast<double>(grey.size()), compare_s / decode_s);

  // One coarse frame a second, and the default coarse_period_s.
  for (const double period_s : {1.0, 0.2})
    replay(grey, probe.frame_offsets_ns, what, period_s, threshold, max_unchanged_s);
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
