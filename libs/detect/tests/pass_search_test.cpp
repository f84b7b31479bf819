#include "lookboth/detect/pass_search.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <optional>
#include <random>
#include <utility>

#include <opencv2/aruco.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace lookboth {
namespace {

/// Frames that show the marker: passes [begin, end).
std::vector<bool> framesWith(std::size_t n,
                             const std::vector<std::pair<std::size_t, std::size_t>>& passes) {
  std::vector<bool> shows(n, false);
  for (const auto& [begin, end] : passes) {
    for (std::size_t i = begin; i < end; ++i) shows[i] = true;
  }
  return shows;
}

/// Runs a search over `shows` (every step-th frame coarse, or the `coarse`
/// frames given), counting how often each frame is examined.
PassSearch searchOver(const std::vector<bool>& shows, std::size_t step, std::vector<int>& calls,
                      const std::optional<std::vector<std::size_t>>& coarse = std::nullopt) {
  calls.assign(shows.size(), 0);
  PassSearch search =
      coarse ? PassSearch(shows.size(), step, *coarse) : PassSearch(shows.size(), step);
  const std::atomic<bool> stop{false};
  search.run(
      [&](std::size_t i, bool) {
        ++calls[i];
        return static_cast<bool>(shows[i]);
      },
      stop);
  return search;
}

TEST(CoarseStep, PeriodOverTheFrameInterval) {
  auto times = [](double hz, int n) {
    std::vector<TimeNs> t;
    for (int i = 0; i < n; ++i) t.push_back(static_cast<TimeNs>(1e12 + i * 1e9 / hz));
    return t;
  };
  EXPECT_EQ(coarseStep(times(30, 100), 0.2), 6u);
  EXPECT_EQ(coarseStep(times(10, 100), 0.2), 2u);
  EXPECT_EQ(coarseStep(times(10, 100), 0.0), 1u);
  EXPECT_EQ(coarseStep(times(4, 100), 0.2), 1u);  // slower than the period: every frame
  EXPECT_EQ(coarseStep(times(30, 1), 0.2), 1u);
  // Dropped frames do not change the step: the median interval.
  std::vector<TimeNs> gappy = times(30, 100);
  gappy.erase(gappy.begin() + 10, gappy.begin() + 40);
  EXPECT_EQ(coarseStep(gappy, 0.2), 6u);
}

TEST(PassSearch, StepOneExaminesEveryFrame) {
  std::vector<int> calls;
  const PassSearch search = searchOver(framesWith(50, {{10, 20}}), 1, calls);
  EXPECT_EQ(search.examined(), 50u);
  for (int c : calls) EXPECT_EQ(c, 1);
}

TEST(PassSearch, FindsEveryFrameOfPassesAtLeastAStepLongExaminingFewOthers) {
  std::mt19937 random(3);
  for (int trial = 0; trial < 200; ++trial) {
    const std::size_t step = 2 + random() % 9;
    const std::size_t n = 500 + random() % 2000;
    std::vector<std::pair<std::size_t, std::size_t>> passes;
    std::size_t visible = 0;
    for (std::size_t at = random() % 200; at < n;) {
      const std::size_t length = step + random() % 120;
      passes.emplace_back(at, std::min(n, at + length));
      visible += std::min(n, at + length) - at;
      at += length + 1 + random() % 400;
    }
    const std::vector<bool> shows = framesWith(n, passes);
    std::vector<int> calls;
    const PassSearch search = searchOver(shows, step, calls);
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_LE(calls[i], 1) << "frame " << i << " examined twice";
      if (shows[i]) {
        ASSERT_TRUE(search.found(i)) << "trial " << trial << " frame " << i;
      }
    }
    // Outside the passes: one frame per step, and a step's worth on each side of a pass.
    const std::size_t bound = visible + (n - visible) / step + 2 * passes.size() * step + 2;
    EXPECT_LE(search.examined(), bound);
  }
}

TEST(PassSearch, PassesWithHolesShorterThanAStepAreFoundWhole) {
  // A detector that misses a few frames inside a pass (blur, a person
  // walking by): the walk goes on across holes shorter than the step.
  std::vector<bool> shows = framesWith(400, {{100, 180}});
  for (std::size_t i : {101u, 120u, 121u, 122u, 150u, 178u}) shows[i] = false;
  std::vector<int> calls;
  const PassSearch search = searchOver(shows, 6, calls);
  for (std::size_t i = 100; i < 180; ++i) EXPECT_EQ(search.found(i), shows[i]) << i;
}

TEST(PassSearch, APassShorterThanTheStepBetweenCoarseFramesIsMissed) {
  // The limit the documentation states: frames 0, 6, 12... are coarse; a pass
  // of 5 frames in between is not seen.
  std::vector<int> calls;
  const PassSearch search = searchOver(framesWith(100, {{13, 18}}), 6, calls);
  for (std::size_t i = 13; i < 18; ++i) EXPECT_FALSE(search.wasExamined(i));
  // ... while one frame longer is always found.
  const PassSearch longer = searchOver(framesWith(100, {{13, 19}}), 6, calls);
  for (std::size_t i = 13; i < 19; ++i) EXPECT_TRUE(longer.found(i)) << i;
}

TEST(PassSearch, TheLastFrameIsExamined) {
  std::vector<int> calls;
  const PassSearch search = searchOver(framesWith(100, {{97, 100}}), 6, calls);
  for (std::size_t i = 97; i < 100; ++i) EXPECT_TRUE(search.found(i)) << i;
}

TEST(PassSearch, GivenCoarseFramesLikeAVideosKeyFrames) {
  // Key frames every 30 frames, walks ending after 6 empty frames: a pass
  // holding a key frame is found whole, the frames between key frames away
  // from it are never examined, and a pass between two key frames is missed.
  std::vector<std::size_t> keys;
  for (std::size_t k = 0; k < 300; k += 30) keys.push_back(k);
  const std::vector<bool> shows = framesWith(300, {{100, 140}, {215, 235}});
  std::vector<int> calls;
  const PassSearch search = searchOver(shows, 6, calls, keys);
  for (std::size_t i = 100; i < 140; ++i) EXPECT_TRUE(search.found(i)) << i;
  for (std::size_t i = 215; i < 235; ++i) EXPECT_FALSE(search.wasExamined(i)) << i;
  for (std::size_t i = 0; i < 300; ++i) EXPECT_LE(calls[i], 1) << i;
  // The key frames and the last frame (120 among them, in the pass), the
  // pass, and 6 empty frames on each side of it.
  EXPECT_EQ(search.examined(), keys.size() + 1 + 40 + 12 - 1);
}

TEST(PassSearch, SaysWhichFramesAreLookedAtAsCoarseFrames) {
  const std::vector<bool> shows = framesWith(60, {{20, 30}});
  PassSearch search(shows.size(), 6);
  std::vector<int> as_coarse(shows.size(), -1);
  const std::atomic<bool> stop{false};
  search.run(
      [&](std::size_t i, bool coarse) {
        as_coarse[i] = coarse ? 1 : 0;
        return static_cast<bool>(shows[i]);
      },
      stop);
  // Coarse frames before the pass, the one that finds it (24), and those
  // after the walk; every frame of the walk (back to 14, on to 35, coarse
  // frame 30 among them) is not.
  for (std::size_t i : {0, 6, 12, 18, 24, 36, 42, 48, 54, 59}) EXPECT_EQ(as_coarse[i], 1) << i;
  for (std::size_t i = 14; i < 36; ++i) {
    if (i != 18 && i != 24) {
      EXPECT_EQ(as_coarse[i], 0) << i;
    }
  }
  EXPECT_EQ(as_coarse[13], -1);
  EXPECT_EQ(as_coarse[37], -1);
}

/// A fixed camera's view: a textured floor and its sensor noise.
cv::Mat floorView(std::mt19937& rng, const cv::Mat& floor, double noise_sigma) {
  cv::Mat noise(floor.size(), CV_32F);
  cv::theRNG().state = rng();
  cv::randn(noise, 0.0, noise_sigma);
  cv::Mat view;
  floor.convertTo(view, CV_32F);
  view += noise;
  view.convertTo(view, CV_8U);
  return view;
}

TEST(SceneChange, QuietViewsAreUnchangedAndTheSmallestMarkerChangesThem) {
  std::mt19937 rng(7);
  cv::Mat floor(540, 960, CV_8U);
  cv::theRNG().state = 11;
  cv::randu(floor, 90, 170);
  cv::GaussianBlur(floor, floor, cv::Size(0, 0), 3.0);  // a concrete floor's texture
  SceneChange view(12);
  EXPECT_TRUE(view.changed(floorView(rng, floor, 3.0)));  // nothing to compare with
  view.keep();
  for (int k = 0; k < 20; ++k) EXPECT_FALSE(view.changed(floorView(rng, floor, 3.0))) << k;
  // A marker of the smallest side the detector accepts (10 px), on a mid-grey
  // robot no larger than itself, anywhere in the view, changes it.
  const auto dictionary = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50);
  cv::Mat marker;
  cv::aruco::drawMarker(dictionary, 3, 10, marker, 1);
  std::uniform_int_distribution<int> x(0, floor.cols - 10), y(0, floor.rows - 10);
  for (int k = 0; k < 50; ++k) {
    cv::Mat with = floorView(rng, floor, 3.0);
    marker.copyTo(with(cv::Rect(x(rng), y(rng), 10, 10)));
    EXPECT_TRUE(view.changed(with)) << k;
  }
  // The exposure (gain and offset, up to +-10 % a frame) changes nothing.
  std::uniform_real_distribution<double> gain(0.9, 1.1), offset(-5, 5);
  for (int k = 0; k < 20; ++k) {
    cv::Mat exposed;
    floor.convertTo(exposed, CV_8U, gain(rng), offset(rng));
    EXPECT_FALSE(view.changed(floorView(rng, exposed, 3.0))) << k;
  }
  // A shadow growing slowly over part of the view adds up against the frame
  // kept, not the last one looked at.
  int changed_at = -1;
  for (int k = 1; k <= 20 && changed_at < 0; ++k) {
    cv::Mat shaded = floor.clone();
    shaded(cv::Rect(0, 0, floor.cols / 3, floor.rows)) -= k;
    if (view.changed(floorView(rng, shaded, 3.0))) changed_at = k;
  }
  EXPECT_GE(changed_at, 5);
  EXPECT_LE(changed_at, 16);
  // Far darker (the light dimmed by more than a fifth): searched.
  cv::Mat dimmed;
  floor.convertTo(dimmed, CV_8U, 0.7);
  EXPECT_TRUE(view.changed(floorView(rng, dimmed, 3.0)));
  // A colour image is not compared: searched.
  cv::Mat colour;
  cv::cvtColor(floor, colour, cv::COLOR_GRAY2BGR);
  EXPECT_TRUE(view.changed(colour));
  // Forgotten (after a pass): the next view counts as changed.
  view.forget();
  EXPECT_TRUE(view.changed(floorView(rng, floor, 3.0)));
  // Threshold 0: always changed.
  SceneChange always(0);
  always.changed(floor);
  always.keep();
  EXPECT_TRUE(always.changed(floor));
}

/// A frame of the real fixed camera (tests/data/views/bgslibrary_road/SOURCE.md).
cv::Mat roadFrame(int n) {
  char name[32];
  std::snprintf(name, sizeof(name), "frame_%03d.png", n);
  const auto path =
      std::filesystem::path(LOOKBOTH_TEST_DATA_DIR) / "views" / "bgslibrary_road" / name;
  cv::Mat grey = cv::imread(path.string(), cv::IMREAD_GRAYSCALE);
  EXPECT_FALSE(grey.empty()) << path;
  return grey;
}

TEST(SceneChange, ARealFixedCamerasEmptyViewsAreUnchangedAndAVehicleEnteringChangesThem) {
  SceneChange view(12);
  EXPECT_TRUE(view.changed(roadFrame(0)));
  view.keep();
  // The road empty 1.9 s and 9.6 s later: the sensor's noise and the codec's.
  EXPECT_FALSE(view.changed(roadFrame(57)));
  EXPECT_FALSE(view.changed(roadFrame(288)));
  // The same view a tenth darker and brighter, 3 levels up: the exposure.
  for (const double gain : {0.9, 1.1}) {
    cv::Mat exposed;
    roadFrame(288).convertTo(exposed, CV_8U, gain, 3.0);
    EXPECT_FALSE(view.changed(exposed)) << gain;
  }
  // A vehicle's first frames at the view's left edge, and the last of one at
  // its right edge.
  for (const int n : {58, 188, 195}) EXPECT_TRUE(view.changed(roadFrame(n))) << n;
  // The empty road after a car passed, the camera still moving (0.4 px from
  // frame 0, by phase correlation): searched, which costs a search, not a pass.
  EXPECT_TRUE(view.changed(roadFrame(373)));
}

TEST(PassSearch, StopsWhenAsked) {
  PassSearch search(1000, 1);
  std::atomic<bool> stop{false};
  search.run(
      [&](std::size_t i, bool) {
        if (i == 10) stop = true;
        return true;
      },
      stop);
  EXPECT_EQ(search.examined(), 11u);
}

}  // namespace
}  // namespace lookboth
