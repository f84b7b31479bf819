#include "lookboth/core/file_lock.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "lookboth/core/progress.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

class PathLockTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_lock_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "ds");
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

// flock locks belong to open file descriptions, so a second descriptor in
// the same process contends like another process would.
TEST_F(PathLockTest, ASecondWriterWaitsForTheFirst) {
  const ProgressReporter progress;
  auto first = std::make_unique<PathLock>(dir_ / "ds", progress);
  ASSERT_TRUE(first->locked());
  EXPECT_TRUE(fs::exists(dir_ / ".ds.lock"));
  EXPECT_FALSE(PathLock(dir_ / "ds").locked());
  EXPECT_FALSE(PathLock(dir_ / "ds" / "").locked());  // the same dataset

  bool told = false;
  std::thread release([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    first.reset();
  });
  const auto start = std::chrono::steady_clock::now();
  {
    const PathLock second(dir_ / "ds", progress, [&] { told = true; });
    EXPECT_TRUE(second.locked());
  }
  release.join();
  EXPECT_TRUE(told);
  EXPECT_GE(std::chrono::steady_clock::now() - start, std::chrono::milliseconds(250));
  EXPECT_FALSE(fs::exists(dir_ / ".ds.lock"));  // removed on release
}

TEST_F(PathLockTest, AStopEndsTheWait) {
  const ProgressReporter progress;
  const PathLock first(dir_ / "ds");
  ASSERT_TRUE(first.locked());
  std::thread stop([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    progress.requestStop();
  });
  EXPECT_THROW(PathLock(dir_ / "ds", progress), StopRequested);
  stop.join();
}

TEST_F(PathLockTest, AKilledHolderReleasesTheLock) {
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const PathLock held(dir_ / "ds");
    ::kill(::getpid(), SIGKILL);  // no destructor runs
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_TRUE(fs::exists(dir_ / ".ds.lock"));  // left behind, but not held
  EXPECT_TRUE(PathLock(dir_ / "ds").locked());
}

TEST_F(PathLockTest, OtherDatasetsAreIndependent) {
  const PathLock a(dir_ / "ds");
  fs::create_directories(dir_ / "other");
  EXPECT_TRUE(a.locked());
  EXPECT_TRUE(PathLock(dir_ / "other").locked());
}

}  // namespace
}  // namespace lookboth
