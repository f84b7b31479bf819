#include "lookboth/core/temporary_files.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

#include "lookboth/core/atomic_file.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

TEST(TemporaryFiles, RecognisesTheProjectsTemporaryNames) {
  EXPECT_EQ(temporaryOwner(".cameras.csv.tmp-1234-0"), 1234);
  EXPECT_EQ(temporaryOwner(".reg.tmp-77"), 77);
  EXPECT_EQ(temporaryOwner(".small.new-42-3.rawlog"), 42);
  EXPECT_EQ(temporaryOwner(".small.new-42-3.yaml"), 42);
  EXPECT_EQ(temporaryOwner(".small.new-42-3_Images"), 42);
  EXPECT_EQ(temporaryOwner(".lookboth-report-9-0"), 9);
  EXPECT_EQ(temporaryOwner(".reg-dataset-tmp-31"), 31);
  EXPECT_EQ(temporaryOwner(".reg-dataset-tmp-31.rawlog"), 31);
  // Not ours, or possibly the only complete copy of a dataset: never removed.
  EXPECT_EQ(temporaryOwner(".small.old-42-3.rawlog"), 0);
  EXPECT_EQ(temporaryOwner("cameras.csv"), 0);
  EXPECT_EQ(temporaryOwner(".bashrc"), 0);
  EXPECT_EQ(temporaryOwner(".x.tmp-abc"), 0);
}

// A run killed with SIGKILL leaves its temporary; the next writer into the
// folder removes it, and leaves a live process's and ordinary files alone.
TEST(TemporaryFiles, AKilledWritersTemporaryIsRemovedByTheNextRun) {
  const fs::path dir = fs::temp_directory_path() / ("lookboth_stale_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    AtomicOutputFile out(dir / "cameras.csv");
    out.stream() << "half";
    out.stream().flush();
    ::kill(::getpid(), SIGKILL);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  const std::string stale = ".cameras.csv.tmp-" + std::to_string(child) + "-0";
  ASSERT_TRUE(fs::exists(dir / stale));
  const std::string live = ".other.tmp-" + std::to_string(::getpid()) + "-5";
  std::ofstream(dir / live) << "in progress";
  std::ofstream(dir / "keep.txt") << "user file";

  EXPECT_EQ(removeStaleTemporaries(dir, /*min_age_s=*/0), 1);
  EXPECT_FALSE(fs::exists(dir / stale));
  EXPECT_TRUE(fs::exists(dir / live));
  EXPECT_TRUE(fs::exists(dir / "keep.txt"));
  fs::remove_all(dir);
}

TEST(TemporaryFiles, ARecentTemporaryIsLeftAlone) {
  const fs::path dir =
      fs::temp_directory_path() / ("lookboth_recent_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  // A pid that cannot be running (above pid_max), but just written: perhaps
  // a writer on another machine sharing the folder.
  std::ofstream(dir / ".x.csv.tmp-999999999-0") << "busy";
  EXPECT_EQ(removeStaleTemporaries(dir, /*min_age_s=*/60), 0);
  EXPECT_TRUE(fs::exists(dir / ".x.csv.tmp-999999999-0"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lookboth
