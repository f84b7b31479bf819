#include "lookboth/geometry/time.h"

#include <cmath>
#include <cstdlib>
#include <limits>

#include "lookboth/core/error.h"

namespace lookboth {

double nsToSeconds(TimeNs t) {
  // Split to keep full precision of the fractional part.
  const TimeNs whole = t / kNanosecondsPerSecond;
  const TimeNs fraction = t % kNanosecondsPerSecond;
  return static_cast<double>(whole) + static_cast<double>(fraction) * 1e-9;
}

TimeNs secondsToNsRounded(double seconds) {
  if (!std::isfinite(seconds) || std::abs(seconds) > 9.2e9) {
    throw Error("time " + std::to_string(seconds) + " s is out of the representable range");
  }
  const double whole = std::trunc(seconds);
  const double fraction = seconds - whole;
  return static_cast<TimeNs>(whole) * kNanosecondsPerSecond +
         static_cast<TimeNs>(std::llround(fraction * 1e9));
}

std::optional<TimeNs> parseSeconds(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r')) {
    text.remove_suffix(1);
  }
  if (text.empty()) return std::nullopt;
  bool negative = false;
  if (text.front() == '-' || text.front() == '+') {
    negative = text.front() == '-';
    text.remove_prefix(1);
  }
  const size_t dot = text.find('.');
  const std::string_view whole = text.substr(0, dot);
  const std::string_view fraction = dot == std::string_view::npos ? "" : text.substr(dot + 1);
  if (whole.empty() && fraction.empty()) return std::nullopt;
  if (whole.size() > 10) return std::nullopt;  // beyond ~317 years
  TimeNs seconds = 0;
  for (char c : whole) {
    if (c < '0' || c > '9') return std::nullopt;
    seconds = seconds * 10 + (c - '0');
  }
  TimeNs nanos = 0;
  int digits = 0;
  bool round_up = false;
  for (char c : fraction) {
    if (c < '0' || c > '9') return std::nullopt;
    if (digits < 9) {
      nanos = nanos * 10 + (c - '0');
    } else if (digits == 9) {
      round_up = c >= '5';
    }
    ++digits;
  }
  for (int i = digits; i < 9; ++i) nanos *= 10;
  if (round_up) ++nanos;
  if (seconds > std::numeric_limits<TimeNs>::max() / kNanosecondsPerSecond - 1) return std::nullopt;
  const TimeNs total = seconds * kNanosecondsPerSecond + nanos;
  return negative ? -total : total;
}

std::string formatSeconds(TimeNs t) {
  const bool negative = t < 0;
  // Work on the magnitude as unsigned so INT64_MIN does not overflow.
  const unsigned long long magnitude = negative ? static_cast<unsigned long long>(-(t + 1)) + 1ULL
                                                : static_cast<unsigned long long>(t);
  const unsigned long long seconds = magnitude / 1'000'000'000ULL;
  const unsigned long long nanos = magnitude % 1'000'000'000ULL;
  std::string fraction = std::to_string(nanos);
  fraction.insert(0, 9 - fraction.size(), '0');
  return (negative ? "-" : "") + std::to_string(seconds) + "." + fraction;
}

mrpt::Clock::time_point toMrptTime(TimeNs t) {
  // Round half away from zero to whole 100 ns ticks.
  TimeNs ticks = t / kNanosecondsPerMrptTick;
  const TimeNs remainder = t % kNanosecondsPerMrptTick;
  if (remainder >= 50) ++ticks;
  if (remainder <= -50) --ticks;
  return mrpt::Clock::time_point(mrpt::Clock::duration(ticks + kMrptTicksAtUnixEpoch));
}

mrpt::Clock::time_point toMrptTimeExact(TimeNs t) {
  if (!isExactMrptTime(t)) {
    throw Error("time " + formatSeconds(t) +
                " s is not a whole number of MRPT's 100 ns ticks and cannot be stored exactly");
  }
  return mrpt::Clock::time_point(
      mrpt::Clock::duration(t / kNanosecondsPerMrptTick + kMrptTicksAtUnixEpoch));
}

TimeNs fromMrptTime(mrpt::Clock::time_point t) {
  const std::int64_t ticks = t.time_since_epoch().count();
  if (ticks == 0) throw Error("invalid (unset) MRPT timestamp");
  constexpr std::int64_t kLimit = std::numeric_limits<TimeNs>::max() / kNanosecondsPerMrptTick;
  // A corrupt stamp near the int64 limits would overflow the subtraction.
  std::int64_t since_unix = 0;
  if (__builtin_sub_overflow(ticks, kMrptTicksAtUnixEpoch, &since_unix) || since_unix > kLimit ||
      since_unix < -kLimit) {
    throw Error("MRPT timestamp " + std::to_string(ticks) +
                " is outside the range of lookboth time");
  }
  return since_unix * kNanosecondsPerMrptTick;
}

std::vector<std::pair<std::size_t, std::size_t>> runsWithinGap(const std::vector<TimeNs>& sorted,
                                                               TimeNs max_gap) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t begin = 0; begin < sorted.size();) {
    std::size_t end = begin + 1;
    while (end < sorted.size() && sorted[end] - sorted[end - 1] <= max_gap) ++end;
    runs.emplace_back(begin, end);
    begin = end;
  }
  return runs;
}

}  // namespace lookboth
