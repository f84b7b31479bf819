// Time in lookboth: signed 64-bit nanoseconds (`TimeNs`), for instants (since
// the Unix epoch, 1970-01-01T00:00:00 UTC, in the clock of the node that
// stamped them) and for durations alike. +-292 years of range.
//
// MRPT stamps are `mrpt::Clock::time_point`: 100 ns ticks since 1601-01-01
// (Windows FILETIME). The conversion is exact from MRPT to lookboth; from
// lookboth to MRPT it rounds to the nearest 100 ns tick (ties away from zero)
// unless the caller asks for an exact conversion.
#pragma once

#include <mrpt/core/Clock.h>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace lookboth {

using TimeNs = std::int64_t;

constexpr TimeNs kNanosecondsPerSecond = 1'000'000'000;
constexpr TimeNs kNanosecondsPerMrptTick = 100;
/// MRPT ticks (100 ns) from 1601-01-01 to 1970-01-01.
constexpr std::int64_t kMrptTicksAtUnixEpoch = 116'444'736'000'000'000LL;

constexpr TimeNs millisecondsToNs(std::int64_t ms) { return ms * 1'000'000; }
constexpr TimeNs secondsToNs(std::int64_t s) { return s * kNanosecondsPerSecond; }

/// Seconds as a double (for printing and for arithmetic on short durations:
/// a double holds an absolute Unix time only to ~0.2 us).
double nsToSeconds(TimeNs t);
/// Nearest nanosecond of a time in seconds. Throws lookboth::Error when out of range or not finite.
TimeNs secondsToNsRounded(double seconds);

/// Exact parse of a decimal number of seconds ("1305031102.175304",
/// "-0.5", "12") into nanoseconds, without going through a double. Up to 9
/// decimals; more decimals are rounded to the nearest nanosecond. nullopt on
/// anything that is not such a number or is out of range.
std::optional<TimeNs> parseSeconds(std::string_view text);
/// "1305031102.175304000": seconds with exactly 9 decimals; reads back exactly with parseSeconds.
std::string formatSeconds(TimeNs t);

/// The runs of ascending times in which no two neighbours are more than
/// `max_gap` apart, as [begin, end) index pairs: a camera's passes.
std::vector<std::pair<std::size_t, std::size_t>> runsWithinGap(const std::vector<TimeNs>& sorted,
                                                               TimeNs max_gap);

/// Thins a stream of frames to at most `max_rate_hz` (0: keeps every
/// frame): a frame is kept when it comes at least 0.99 / max_rate_hz after
/// the last one kept (the first always; 1 % for the jitter of the stamps).
/// A 30 Hz stream at 15 keeps every other frame, at 10 every third; a 10
/// Hz stream at 15 keeps every frame.
class RateLimiter {
 public:
  explicit RateLimiter(double max_rate_hz)
      : min_gap_(max_rate_hz > 0 ? static_cast<TimeNs>(0.99e9 / max_rate_hz) : 0) {}
  bool keep(TimeNs t) {
    if (any_ && t - last_ < min_gap_) return false;
    any_ = true;
    last_ = t;
    return true;
  }

 private:
  TimeNs min_gap_;
  bool any_ = false;  ///< A frame was kept (last_ is its time).
  TimeNs last_ = 0;
};

/// True when t is a whole number of MRPT ticks (a multiple of 100 ns).
constexpr bool isExactMrptTime(TimeNs t) { return t % kNanosecondsPerMrptTick == 0; }

/// Nearest MRPT tick (ties away from zero).
mrpt::Clock::time_point toMrptTime(TimeNs t);
/// Exact conversion; throws lookboth::Error when t is not a multiple of 100 ns.
mrpt::Clock::time_point toMrptTimeExact(TimeNs t);
/// Exact. Throws lookboth::Error for MRPT's invalid (default-constructed, 0)
/// stamp and for stamps outside the range of TimeNs.
TimeNs fromMrptTime(mrpt::Clock::time_point t);

}  // namespace lookboth
