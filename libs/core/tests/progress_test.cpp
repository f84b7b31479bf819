#include "lookboth/core/progress.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace lookboth {
namespace {

TEST(Progress, DeliversEventsAndSharesTheStopFlagAcrossCopies) {
  std::vector<ProgressEvent> events;
  ProgressReporter reporter([&](const ProgressEvent& e) { events.push_back(e); });
  const ProgressReporter copy = reporter;
  copy.report("convert", 3, 10, "frames");
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].stage, "convert");
  EXPECT_EQ(events[0].done, 3);
  EXPECT_NO_THROW(copy.checkStop());
  reporter.requestStop();
  EXPECT_TRUE(copy.stopRequested());
  EXPECT_THROW(copy.checkStop(), StopRequested);
}

std::string capture(bool terminal, int events) {
  std::FILE* file = std::tmpfile();
  ProgressCallback print = makeConsoleProgress(file, terminal);
  for (int i = 0; i <= events; ++i) print(ProgressEvent{"convert", i, events, ""});
  std::fflush(file);
  std::rewind(file);
  std::string text;
  char buffer[4096];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof(buffer), file)) > 0) text.append(buffer, n);
  std::fclose(file);
  return text;
}

TEST(Progress, PlainLinesWhenNotATerminal) {
  const std::string text = capture(false, 1000);
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_NE(text.find("convert: 1000/1000 (100%)\n"), std::string::npos) << text;
  // One line per 5 % step plus the first: 21 lines, not 1001.
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 21) << text;
}

TEST(Progress, BarOnATerminal) {
  const std::string text = capture(true, 1000);
  EXPECT_NE(text.find('\r'), std::string::npos);
  EXPECT_NE(text.find("[##############################] 100% 1000/1000"), std::string::npos)
      << text;
  EXPECT_EQ(text.back(), '\n');  // the finished bar ends its line
}

}  // namespace
}  // namespace lookboth
