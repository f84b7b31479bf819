// End-to-end test of lookboth-studio under Xvfb: simulate a short `small`
// run, open it, select a camera, save screenshots of the window and of each
// view, exit; then check that the pictures show what a technician must see.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

namespace {

namespace fs = std::filesystem;

// Pixels of `image` (BGR) within `tolerance` of the colour `rgb`.
int countColour(const cv::Mat& image, cv::Vec3b rgb, int tolerance) {
  int n = 0;
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      const cv::Vec3b p = image.at<cv::Vec3b>(r, c);
      if (std::abs(p[2] - rgb[0]) <= tolerance && std::abs(p[1] - rgb[1]) <= tolerance &&
          std::abs(p[0] - rgb[2]) <= tolerance)
        ++n;
    }
  }
  return n;
}

std::string readText(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

double stddev(const cv::Mat& image) {
  cv::Scalar mean;
  cv::Scalar sd;
  cv::meanStdDev(image, mean, sd);
  return (sd[0] + sd[1] + sd[2]) / 3;
}

class StudioScreenshotTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / "lookboth_studio_screenshot_test";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure() && !std::getenv("LOOKBOTH_KEEP_TEST_OUTPUT")) fs::remove_all(dir_);
  }
  // Runs the app under Xvfb in the work dir with `arguments`; returns its exit status.
  int runStudio(const std::string& arguments) {
    // HOME in the work dir: the app's recent-files settings go there, not to the user's.
    const std::string command = "cd " + dir_.string() + " && HOME=" + dir_.string() +
                                " xvfb-run -a -s '-screen 0 1600x1000x24' " LOOKBOTH_STUDIO_EXE
                                " " +
                                arguments + " > studio.log 2>&1";
    return std::system(command.c_str());
  }
  fs::path dir_;
};

TEST_F(StudioScreenshotTest, SimulatesOpensAndShowsEveryView) {
  const fs::path shot = dir_ / "studio.png";
  ASSERT_EQ(runStudio("--simulate small --detections-only --duration 30 --simulate-out " +
                      (dir_ / "small.rawlog").string() +
                      " --run-all --trajectory metric --select cam01 --export-report report"
                      " --export-registration exported --screenshot " +
                      shot.string() + " --exit"),
            0)
      << "see " << (dir_ / "studio.log");
  // The whole pipeline ran through the button's code path and wrote a registration.
  EXPECT_TRUE(fs::exists(dir_ / "small_registration" / "registration.yaml"));
  EXPECT_TRUE(fs::exists(dir_ / "small_registration" / "cameras.csv"));
  // File > Export registration and File > Export report.
  EXPECT_TRUE(fs::exists(dir_ / "exported" / "cameras.csv"));
  EXPECT_TRUE(fs::exists(dir_ / "exported" / "registration.yaml"));
  const std::string html = readText(dir_ / "report" / "report.html");
  EXPECT_NE(html.find("<html"), std::string::npos) << "no HTML report in " << dir_ / "report";
  EXPECT_NE(html.find("cam01"), std::string::npos) << "the report has no camera table";
  EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos) << "no picture in the report";
  const std::string log = readText(dir_ / "studio.log");
  EXPECT_NE(log.find("report written:"), std::string::npos) << log;

  const cv::Mat window = cv::imread(shot.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(window.empty()) << shot;
  EXPECT_GE(window.cols, 1200);
  EXPECT_GE(window.rows, 800);
  EXPECT_GT(stddev(window), 20.0) << "the window looks blank";

  // The 3-D view: trajectory (blue) and cameras (green frustums), not just background.
  const cv::Mat scene = cv::imread((dir_ / "studio-scene.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(scene.empty());
  EXPECT_GT(countColour(scene, {80, 160, 255}, 40), 50) << "no trajectory in the 3-D view";
  EXPECT_GT(countColour(scene, {40, 200, 80}, 40) + countColour(scene, {255, 200, 0}, 40), 20)
      << "no camera in the 3-D view";

  // The fisheye view: the frame (a blank canvas for detections only) with the overlay colours.
  const cv::Mat fisheye = cv::imread((dir_ / "studio-fisheye.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(fisheye.empty());
  EXPECT_GT(stddev(fisheye), 5.0) << "the fisheye view looks blank";
  // The report's overlay colours (libs/report/include/lookboth/report/draw.h), in RGB.
  EXPECT_GT(countColour(fisheye, {0, 200, 0}, 30), 10) << "no detected blob drawn";
  EXPECT_GT(countColour(fisheye, {0, 128, 255}, 30), 10) << "no camera projected after refinement";
  EXPECT_GT(countColour(fisheye, {255, 0, 0}, 30), 5) << "no camera projected before refinement";

  // The camera table: rows of dark text on a light background.
  const cv::Mat table = cv::imread((dir_ / "studio-table.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(table.empty());
  EXPECT_GT(cv::countNonZero(table < 110), 300) << "the camera table looks empty";
}

// The stages one at a time (--run-until runs the same step buttons in turn):
// after look_down the cameras are registered and shown, looking up has not run
// and nothing is written yet.
TEST_F(StudioScreenshotTest, RunsTheStagesOneByOne) {
  const fs::path shot = dir_ / "steps.png";
  ASSERT_EQ(runStudio("--simulate small --detections-only --duration 30 --simulate-out " +
                      (dir_ / "small.rawlog").string() +
                      " --run-until look_down --trajectory metric --select cam01 --screenshot " +
                      shot.string() + " --exit"),
            0)
      << "see " << (dir_ / "studio.log");
  const std::string log = readText(dir_ / "studio.log");
  const char* in_order[] = {"detect: skipped (no frames: detections-only dataset)",
                            "odometry: skipped (metric trajectory)", "associate: ",
                            "motion_calibration: ", "look_down: 6 of 6 cameras registered"};
  size_t at = 0;
  for (const char* line : in_order) {
    const size_t found = log.find(line, at);
    ASSERT_NE(found, std::string::npos) << "missing or out of order: '" << line << "'\n" << log;
    at = found;
  }
  EXPECT_EQ(log.find("look_up: "), std::string::npos) << "look_up ran:\n" << log;
  // The registration directory is written when the last stage has run.
  EXPECT_FALSE(fs::exists(dir_ / "small_registration"));

  // The cameras registered by looking down are in the 3-D view and the table.
  const cv::Mat scene = cv::imread((dir_ / "steps-scene.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(scene.empty());
  EXPECT_GT(countColour(scene, {40, 200, 80}, 40) + countColour(scene, {255, 200, 0}, 40), 20)
      << "no registered camera in the 3-D view";
  const cv::Mat table = cv::imread((dir_ / "steps-table.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(table.empty());
  EXPECT_GT(cv::countNonZero(table < 110), 300) << "the camera table looks empty";
  // The fisheye view shows the cameras where looking down put them (blue discs).
  const cv::Mat fisheye = cv::imread((dir_ / "steps-fisheye.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(fisheye.empty());
  EXPECT_GT(countColour(fisheye, {0, 128, 255}, 30), 10) << "no camera projected";
}

// The fisheye overlay toggle: "before" shows the cameras where looking down
// put them (red crosses) and not the refined ones (blue discs); "after" the
// opposite. The legend is the same in both, so the differences are the overlay.
TEST_F(StudioScreenshotTest, OverlayShowsBeforeOrAfterRefinement) {
  const std::string common = " --run-all --trajectory metric --select cam01 --exit";
  ASSERT_EQ(runStudio("--simulate small --detections-only --duration 30 --simulate-out " +
                      (dir_ / "small.rawlog").string() + common + " --overlay before" +
                      " --screenshot " + (dir_ / "before.png").string()),
            0)
      << "see " << (dir_ / "studio.log");
  ASSERT_EQ(runStudio((dir_ / "small.rawlog").string() + common + " --overlay after" +
                      " --screenshot " + (dir_ / "after.png").string()),
            0)
      << "see " << (dir_ / "studio.log");
  const cv::Mat before = cv::imread((dir_ / "before-fisheye.png").string(), cv::IMREAD_COLOR);
  const cv::Mat after = cv::imread((dir_ / "after-fisheye.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(before.empty());
  ASSERT_FALSE(after.empty());
  const cv::Vec3b red{255, 0, 0};
  const cv::Vec3b blue{0, 128, 255};
  EXPECT_GT(countColour(before, red, 30), countColour(after, red, 30) + 10)
      << "'before' shows no more red crosses than 'after'";
  EXPECT_GT(countColour(after, blue, 30), countColour(before, blue, 30) + 10)
      << "'after' shows no more blue discs than 'before'";
}

// File > Load camera calibration through --calibration: a calibration file is
// loaded into the dataset's manifest; a bad file or an unknown camera fails
// with a message naming the file or the camera (exit status 1).
TEST_F(StudioScreenshotTest, LoadsCameraCalibrations) {
  const std::string good = LOOKBOTH_TEST_DATA_DIR "/cameras/opencv_pinhole.yaml";
  ASSERT_EQ(
      runStudio("--simulate small --detections-only --duration 5 --simulate-out " +
                (dir_ / "small.rawlog").string() + " --calibration cam05=" + good + " --exit"),
      0)
      << "see " << (dir_ / "studio.log");
  EXPECT_NE(readText(dir_ / "studio.log").find("cam05: calibration from " + good),
            std::string::npos);
  // The manifest (small.yaml beside the rawlog) now holds the pinhole model for cam05.
  const std::string manifest = readText(dir_ / "small.yaml");
  EXPECT_NE(manifest.find("pinhole"), std::string::npos) << manifest;

  EXPECT_NE(runStudio((dir_ / "small.rawlog").string() + " --calibration cam04=" +
                      LOOKBOTH_TEST_DATA_DIR "/cameras/lookboth_bad_number.yaml" +
                      " --calibration cam99=" + good + " --exit"),
            0);
  const std::string log = readText(dir_ / "studio.log");
  EXPECT_NE(log.find("lookboth_bad_number.yaml:"), std::string::npos) << log;
  EXPECT_NE(log.find("no camera 'cam99'"), std::string::npos) << log;
}

}  // namespace
