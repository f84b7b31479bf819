#include "lookboth/core/error.h"

#include <gtest/gtest.h>

namespace lookboth {
namespace {

TEST(Error, FormatsEveryPartThatIsSet) {
  const Error e({"cams/f.yaml", 12, "camera_matrix.data", "cam07"}, "expected 9 numbers, got 8");
  EXPECT_STREQ(e.what(), "cams/f.yaml:12: 'camera_matrix.data': expected 9 numbers, got 8 [cam07]");
  EXPECT_EQ(e.message(), "expected 9 numbers, got 8");
  EXPECT_EQ(e.context().line, 12);
}

TEST(Error, LeavesOutUnknownParts) {
  EXPECT_STREQ(Error({"a.txt", 0, "", ""}, "broken").what(), "a.txt: broken");
  EXPECT_STREQ(Error({"", 0, "xi", ""}, "must be in [-1, 1]").what(), "'xi': must be in [-1, 1]");
  EXPECT_STREQ(Error("plain").what(), "plain");
}

}  // namespace
}  // namespace lookboth
