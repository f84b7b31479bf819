// Seeds of the statistical unit tests, shifted by LOOKBOTH_TEST_SEED_OFFSET.
//
// A test that adds random noise, solves and checks a bound (a NEES, an RMSE
// against its prediction) sees one noise realisation: the bound may hold on
// that draw by luck. scripts/seed_sweep.sh runs these tests again with the
// variable set to 1, 2, ..., each a new realisation, so that a bound is shown
// to hold over the statistic's spread. Unset (or 0), every seed is the test's
// own and the test draws what it always drew.
#pragma once

#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace lookboth {

/// The integer in LOOKBOTH_TEST_SEED_OFFSET, 0 when unset or empty. Anything
/// but decimal digits (at most 2^32 - 1) throws std::invalid_argument naming
/// the variable, so that a typo fails the test instead of testing seed 0.
inline std::uint32_t testSeedOffset() {
  const char* text = std::getenv("LOOKBOTH_TEST_SEED_OFFSET");
  if (text == nullptr || *text == '\0') return 0;
  std::uint64_t value = 0;
  for (const char* c = text; *c != '\0'; ++c) {
    if (*c < '0' || *c > '9' || value > UINT32_MAX / 10) {
      throw std::invalid_argument("LOOKBOTH_TEST_SEED_OFFSET='" + std::string(text) +
                                  "': not a non-negative integer below 2^32");
    }
    value = value * 10 + static_cast<std::uint64_t>(*c - '0');
  }
  if (value > UINT32_MAX) {
    throw std::invalid_argument("LOOKBOTH_TEST_SEED_OFFSET='" + std::string(text) +
                                "': not a non-negative integer below 2^32");
  }
  return static_cast<std::uint32_t>(value);
}

/// `seed` plus the offset: a test's random stream, another one per offset.
inline std::uint32_t testSeed(std::uint32_t seed) { return seed + testSeedOffset(); }

/// The first of a test's `count` consecutive seeds (first, first + 1, ...),
/// shifted by whole blocks of `count`: each offset draws a set of seeds no
/// other offset draws, so that a mean over the set is a new sample each time.
inline std::uint32_t testSeedBlock(std::uint32_t first, std::uint32_t count) {
  return first + count * testSeedOffset();
}

}  // namespace lookboth
