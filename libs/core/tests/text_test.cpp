#include "lookboth/core/text.h"

#include <gtest/gtest.h>

#include <clocale>

namespace lookboth {
namespace {

TEST(Text, ParsesDoublesStrictly) {
  EXPECT_EQ(parseDouble("1.5"), 1.5);
  EXPECT_EQ(parseDouble(" -2e-3 "), -2e-3);
  EXPECT_EQ(parseDouble("+4"), 4.0);
  EXPECT_FALSE(parseDouble("1.5x"));
  EXPECT_FALSE(parseDouble(""));
  EXPECT_FALSE(parseDouble("1,5"));
}

TEST(Text, IgnoresTheLocaleDecimalSeparator) {
  // de_DE may not be installed; the point is that whatever locale is active,
  // a point is parsed and printed.
  std::setlocale(LC_NUMERIC, "de_DE.UTF-8");
  EXPECT_EQ(parseDouble("0.25"), 0.25);
  EXPECT_EQ(formatFixed(0.25, 3), "0.250");
  std::setlocale(LC_NUMERIC, "C");
}

TEST(Text, FormatDoubleRoundTrips) {
  for (double v : {0.1, 1.0 / 3.0, -123456.789e-12, 6.02214076e23}) {
    EXPECT_EQ(parseDouble(formatDouble(v)), v);
  }
}

TEST(Text, ParsesIntegersAndSplits) {
  EXPECT_EQ(parseInt("1305031102175304000"), 1305031102175304000LL);
  EXPECT_FALSE(parseInt("12.0"));
  const auto tokens = splitWhitespace("  a\tbb  c \n");
  ASSERT_EQ(tokens.size(), 3u);
  EXPECT_EQ(tokens[1], "bb");
}

TEST(Text, WrapSentencesPutsEachSentenceOnItsLineWithinTheWidth) {
  EXPECT_EQ(wrapSentences("One. Two  words. Three", "  "), "  One.\n  Two words.\n  Three");
  EXPECT_EQ(wrapSentences(""), "");
  // Wrapped at spaces to the width, indent included; a longer word stays whole.
  EXPECT_EQ(wrapSentences("aaa bbb ccc ddd", "> ", 9), "> aaa bbb\n> ccc ddd");
  EXPECT_EQ(wrapSentences("abcdefghijkl x", "", 5), "abcdefghijkl\nx");
}

}  // namespace
}  // namespace lookboth
