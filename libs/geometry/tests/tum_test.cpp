#include "lookboth/geometry/tum.h"

#include <gtest/gtest.h>

#include "lookboth/core/atomic_file.h"
#include "test_utils.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

class TumTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_tum_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(TumTest, WriteReadRoundTripIsExact) {
  std::mt19937 rng(41);
  Trajectory trajectory;
  for (int i = 0; i < 100; ++i) {
    trajectory.append(1305031102175304123LL + i * 33'333'333LL, testing::randomPose(rng));
  }
  const fs::path path = dir_ / "traj.tum";
  writeTumFile(path, trajectory);
  const Trajectory back = readTumFile(path);
  ASSERT_EQ(back.size(), trajectory.size());
  for (size_t i = 0; i < back.size(); ++i) {
    EXPECT_EQ(back.samples()[i].t, trajectory.samples()[i].t);
    EXPECT_EQ(back.samples()[i].world_from_body.translation,
              trajectory.samples()[i].world_from_body.translation);
    EXPECT_LT(rotationAngleBetween(back.samples()[i].world_from_body.rotation,
                                   trajectory.samples()[i].world_from_body.rotation),
              1e-15);
  }
}

TEST_F(TumTest, ReadsCommentsAndStandardRows) {
  const fs::path path = dir_ / "in.txt";
  writeFileAtomically(path,
                      "# ground truth trajectory\n"
                      "\n"
                      "1305031098.6659 1.3563 0.6305 1.6380 0.6132 0.5962 -0.3311 -0.3986\n"
                      "1305031098.6758 1.3543 0.6306 1.6360 0.6129 0.5966 -0.3316 -0.3980\n");
  const Trajectory trajectory = readTumFile(path);
  ASSERT_EQ(trajectory.size(), 2u);
  EXPECT_EQ(trajectory.startTime(), 1305031098665900000LL);
  EXPECT_DOUBLE_EQ(trajectory.samples()[0].world_from_body.translation.x(), 1.3563);
}

void expectErrorMentions(const fs::path& path, const std::string& contents,
                         const std::vector<std::string>& needles) {
  writeFileAtomically(path, contents);
  try {
    readTumFile(path);
    FAIL() << "expected an error for:\n" << contents;
  } catch (const Error& e) {
    for (const auto& needle : needles) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  }
}

// Editors and spreadsheet exports may start a file with a byte-order mark.
TEST_F(TumTest, AByteOrderMarkIsNotPartOfTheFirstLine) {
  const fs::path path = dir_ / "bom.tum";
  writeFileAtomically(path, "\xEF\xBB\xBF# t x y z qx qy qz qw\n1.0 0 0 0 0 0 0 1\n");
  EXPECT_EQ(readTumFile(path).size(), 1u);
  writeFileAtomically(path,
                      "\xEF\xBB\xBF"
                      "1.0 0 0 0 0 0 0 1\n2.0 1 0 0 0 0 0 1\n");
  EXPECT_EQ(readTumFile(path).size(), 2u);
}

TEST_F(TumTest, ErrorsNameTheFileAndLine) {
  const fs::path path = dir_ / "bad.tum";
  const std::string good = "1.0 0 0 0 0 0 0 1\n";
  expectErrorMentions(path, good + "2.0 0 0 0 0 0 1\n", {"bad.tum:2", "expected 8 values"});
  expectErrorMentions(path, "# c\n" + good + "2.0 0 0 x 0 0 0 1\n", {"bad.tum:3", "'x'", "tz"});
  expectErrorMentions(path, good + "2.0 0 0 0 0 0 0 2\n", {"bad.tum:2", "norm"});
  expectErrorMentions(path, good + "1.0 0 0 0 0 0 0 1\n", {"bad.tum:2", "repeats"});
  expectErrorMentions(path, good + "0.5 0 0 0 0 0 0 1\n", {"bad.tum:2", "earlier"});
  expectErrorMentions(path, "t 0 0 0 0 0 0 1\n", {"bad.tum:1", "timestamp"});
  EXPECT_THROW(readTumFile(dir_ / "missing.tum"), Error);
}

}  // namespace
}  // namespace lookboth
