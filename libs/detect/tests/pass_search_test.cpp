#include "lookboth/detect/pass_search.h"

#include <gtest/gtest.h>

#include <optional>
#include <random>
#include <utility>

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
      [&](std::size_t i) {
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

TEST(PassSearch, StopsWhenAsked) {
  PassSearch search(1000, 1);
  std::atomic<bool> stop{false};
  search.run(
      [&](std::size_t i) {
        if (i == 10) stop = true;
        return true;
      },
      stop);
  EXPECT_EQ(search.examined(), 11u);
}

}  // namespace
}  // namespace lookboth
