#include "lookboth/core/atomic_file.h"

#include <gtest/gtest.h>

#include "lookboth/core/error.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

class AtomicFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_atomic_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
            "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  size_t countEntries() const {
    size_t n = 0;
    for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir_)) ++n;
    return n;
  }
  fs::path dir_;
};

TEST_F(AtomicFileTest, CommitReplacesDestination) {
  const fs::path target = dir_ / "out.txt";
  writeFileAtomically(target, "old");
  {
    AtomicOutputFile out(target);
    out.stream() << "new contents";
    EXPECT_EQ(readFile(target), "old");  // not visible before commit
    out.commit();
  }
  EXPECT_EQ(readFile(target), "new contents");
  EXPECT_EQ(countEntries(), 1u);  // no temporary left behind
}

TEST_F(AtomicFileTest, AbandonedWriteLeavesDestinationUntouched) {
  const fs::path target = dir_ / "out.txt";
  writeFileAtomically(target, "keep me");
  try {
    AtomicOutputFile out(target);
    out.stream() << "partial";
    throw std::runtime_error("interrupted");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(readFile(target), "keep me");
  EXPECT_EQ(countEntries(), 1u);
}

TEST_F(AtomicFileTest, MissingDirectoryNamesTheFile) {
  const fs::path target = dir_ / "no_such_dir" / "out.txt";
  try {
    AtomicOutputFile out(target);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("out.txt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
}

TEST_F(AtomicFileTest, ReadMissingFileNamesIt) {
  try {
    readFile(dir_ / "missing.yaml");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.yaml"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lookboth
