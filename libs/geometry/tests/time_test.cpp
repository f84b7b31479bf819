#include "lookboth/geometry/time.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "lookboth/core/error.h"

namespace lookboth {
namespace {

TEST(Time, MrptEpochIsTheUnixEpochAtTheDocumentedOffset) {
  EXPECT_EQ(toMrptTime(0), mrpt::Clock::fromDouble(0.0));
  EXPECT_EQ(fromMrptTime(mrpt::Clock::fromDouble(1.5)), 1'500'000'000);
  EXPECT_DOUBLE_EQ(mrpt::Clock::toDouble(toMrptTime(secondsToNs(1700000000))), 1700000000.0);
}

TEST(Time, RoundTripsExactlyThroughMrptTicks) {
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<TimeNs> u(-secondsToNs(1'000'000'000), secondsToNs(4'000'000'000));
  for (int i = 0; i < 10000; ++i) {
    const TimeNs t = u(rng) / 100 * 100;
    EXPECT_EQ(fromMrptTime(toMrptTimeExact(t)), t);
    EXPECT_EQ(fromMrptTime(toMrptTime(t)), t);
  }
}

TEST(Time, RoundsToNearestTickAndRefusesInexactWhenAsked) {
  const TimeNs base = secondsToNs(1700000000);
  EXPECT_EQ(fromMrptTime(toMrptTime(base + 49)), base);
  EXPECT_EQ(fromMrptTime(toMrptTime(base + 50)), base + 100);
  EXPECT_EQ(fromMrptTime(toMrptTime(-149)), -100);
  EXPECT_EQ(fromMrptTime(toMrptTime(-150)), -200);
  EXPECT_FALSE(isExactMrptTime(base + 1));
  EXPECT_THROW(toMrptTimeExact(base + 1), Error);
}

TEST(Time, InvalidMrptStampIsAnError) {
  EXPECT_THROW(fromMrptTime(mrpt::Clock::time_point()), Error);
  // Corrupt stamps at the ends of int64 (found by fuzz_rawlog): an error, not
  // an overflow of the epoch subtraction.
  for (const std::int64_t ticks :
       {std::numeric_limits<std::int64_t>::min(), std::numeric_limits<std::int64_t>::min() + 1,
        std::numeric_limits<std::int64_t>::max()}) {
    EXPECT_THROW(fromMrptTime(mrpt::Clock::time_point(mrpt::Clock::duration(ticks))), Error)
        << ticks;
  }
}

TEST(Time, ParsesDecimalSecondsExactly) {
  EXPECT_EQ(parseSeconds("1305031102.175304"), 1305031102175304000LL);
  EXPECT_EQ(parseSeconds("1305031102.175304123"), 1305031102175304123LL);
  EXPECT_EQ(parseSeconds("1305031102.1753041236"), 1305031102175304124LL);  // rounded
  EXPECT_EQ(parseSeconds("12"), 12'000'000'000LL);
  EXPECT_EQ(parseSeconds("-0.5"), -500'000'000LL);
  EXPECT_EQ(parseSeconds(".25"), 250'000'000LL);
  EXPECT_FALSE(parseSeconds(""));
  EXPECT_FALSE(parseSeconds("1.2.3"));
  EXPECT_FALSE(parseSeconds("1e9"));
  EXPECT_FALSE(parseSeconds("abc"));
  EXPECT_FALSE(parseSeconds("99999999999999"));
}

TEST(Time, FormatsSecondsThatParseBackExactly) {
  for (TimeNs t : {TimeNs(0), TimeNs(1), TimeNs(-1), TimeNs(1305031102175304123LL),
                   TimeNs(-1305031102175304123LL)}) {
    EXPECT_EQ(parseSeconds(formatSeconds(t)), t) << formatSeconds(t);
  }
  EXPECT_EQ(formatSeconds(1'500'000'000), "1.500000000");
  EXPECT_EQ(formatSeconds(-1), "-0.000000001");
}

TEST(Time, DoubleSecondsConversions) {
  EXPECT_DOUBLE_EQ(nsToSeconds(1'250'000'000), 1.25);
  EXPECT_EQ(secondsToNsRounded(1.25), 1'250'000'000);
  EXPECT_EQ(secondsToNsRounded(-0.0000000014), -1);
  EXPECT_THROW(secondsToNsRounded(std::nan("")), Error);
}

TEST(Time, RunsWithinGapSplitAtLongerGapsOnly) {
  using Runs = std::vector<std::pair<std::size_t, std::size_t>>;
  EXPECT_EQ(runsWithinGap({}, 10), Runs{});
  EXPECT_EQ(runsWithinGap({5}, 10), (Runs{{0, 1}}));
  // A gap of exactly max_gap stays inside the run; one more nanosecond splits it.
  EXPECT_EQ(runsWithinGap({0, 10, 20, 31, 41, 100}, 10), (Runs{{0, 3}, {3, 5}, {5, 6}}));
}

TEST(RateLimiter, ThinsAStreamToAtMostTheRate) {
  // Which of `count` frames at `rate_hz` (stamps jittered by up to 0.2 ms)
  // a limiter at `max_hz` keeps.
  auto kept = [](double rate_hz, double max_hz, int count) {
    RateLimiter limiter(max_hz);
    std::vector<int> out;
    for (int k = 0; k < count; ++k) {
      const TimeNs jitter = (k % 3 - 1) * 200'000;
      if (limiter.keep(1'700'000'000'000'000'000 + static_cast<TimeNs>(k * 1e9 / rate_hz) + jitter))
        out.push_back(k);
    }
    return out;
  };
  EXPECT_EQ(kept(30, 15, 9), (std::vector<int>{0, 2, 4, 6, 8}));
  EXPECT_EQ(kept(30, 10, 10), (std::vector<int>{0, 3, 6, 9}));
  EXPECT_EQ(kept(10, 15, 5), (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(kept(10, 10, 5), (std::vector<int>{0, 1, 2, 3, 4}));  // the jitter within 1 %
  EXPECT_EQ(kept(30, 0, 4), (std::vector<int>{0, 1, 2, 3}));      // 0: every frame
}

}  // namespace
}  // namespace lookboth
