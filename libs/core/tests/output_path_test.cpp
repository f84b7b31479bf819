#include "lookboth/core/output_path.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>

#include "lookboth/core/error.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

class OutputPathTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_output_path_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "ds" / "images");
    std::ofstream(dir_ / "x.rawlog") << "data";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string errorOf(const fs::path& out, const std::vector<fs::path>& inputs, bool overwrite) {
    try {
      checkOutputPath(out, inputs, overwrite);
    } catch (const Error& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(OutputPathTest, SameFileHoweverSpelled) {
  EXPECT_TRUE(sameFile(dir_ / "x.rawlog", dir_ / "ds" / ".." / "x.rawlog"));
  EXPECT_TRUE(sameFile(dir_ / "ds", dir_ / "ds" / ""));
  fs::create_symlink(dir_ / "x.rawlog", dir_ / "link.rawlog");
  EXPECT_TRUE(sameFile(dir_ / "link.rawlog", dir_ / "x.rawlog"));
  fs::create_hard_link(dir_ / "x.rawlog", dir_ / "hard.rawlog");
  EXPECT_TRUE(sameFile(dir_ / "hard.rawlog", dir_ / "x.rawlog"));
  EXPECT_FALSE(sameFile(dir_ / "y.rawlog", dir_ / "x.rawlog"));
  EXPECT_TRUE(sameFile(dir_ / "new" / ".." / "y.txt", dir_ / "y.txt"));  // neither exists
}

TEST_F(OutputPathTest, RefusesTheInputEvenWithOverwrite) {
  const std::string why = errorOf(dir_ / "ds" / ".." / "x.rawlog", {dir_ / "x.rawlog"}, true);
  EXPECT_NE(why.find("is the input"), std::string::npos) << why;
  EXPECT_NE(errorOf(dir_ / "ds/", {dir_ / "ds"}, true).find("is the input"), std::string::npos);
}

TEST_F(OutputPathTest, RefusesAFolderThatHoldsAnInput) {
  // Replacing dir_ would delete ds/images.
  const std::string why = errorOf(dir_, {dir_ / "ds" / "images"}, true);
  EXPECT_NE(why.find("contains the input"), std::string::npos) << why;
  EXPECT_TRUE(contains(dir_, dir_ / "ds" / "images" / "a.png"));
  EXPECT_FALSE(contains(dir_ / "ds", dir_ / "dsx"));
  EXPECT_FALSE(contains(dir_ / "ds", dir_ / "ds"));
}

TEST_F(OutputPathTest, AnExistingOutputNeedsOverwrite) {
  std::ofstream(dir_ / "report.html") << "old";
  const std::string why = errorOf(dir_ / "report.html", {dir_ / "x.rawlog"}, false);
  EXPECT_NE(why.find("already exists (use --overwrite"), std::string::npos) << why;
  EXPECT_EQ(errorOf(dir_ / "report.html", {dir_ / "x.rawlog"}, true), "");
  EXPECT_EQ(errorOf(dir_ / "new.html", {dir_ / "x.rawlog"}, false), "");
}

}  // namespace
}  // namespace lookboth
