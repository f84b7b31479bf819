// evaluateRegistration() and writeReport() on a registration saved to disk
// (made from the simulator's ground truth), and the HTML rendered by a real
// browser: Debian's chromium, headless, to a PNG that must not be blank.
#include <gtest/gtest.h>
#include <unistd.h>

#include <mrpt/opengl/COpenGLScene.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/report/pose_comparison.h"
#include "lookboth/report/report.h"
#include "lookboth/report/scene.h"
#include "lookboth/sim/simulate.h"
#include "truth_registration.h"

namespace lookboth::report {
namespace {

namespace fs = std::filesystem;

class ReportTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("lookboth_report_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    sim::SimulateOptions options;
    options.scenario = "small";
    options.out = dir_ / "small.rawlog";
    options.detections_only = true;
    options.max_duration_s = 14;
    sim::simulate(options, ProgressReporter());
    dataset_ = options.out;
    registration_ = testing::registrationFromTruth(dataset_, Eigen::Vector3d(0.12, 0.0, -0.06));
    saveRegistration(registration_, dir_ / "reg");
  }
  static void TearDownTestSuite() {
    if (!std::getenv("LOOKBOTH_KEEP_TEST_OUTPUT")) fs::remove_all(dir_);
  }
  // A report without pictures but one fisheye frame, to `name`.html: the
  // tests that read its text, not its pictures.
  static ReportOptions textOnly(const std::string& name) {
    ReportOptions options;
    options.out = dir_ / (name + ".html");
    options.overview = false;
    options.max_env_views = 0;
    options.auto_frames = 1;
    return options;
  }
  static fs::path dir_, dataset_;
  static Registration registration_;
};
fs::path ReportTest::dir_, ReportTest::dataset_;
Registration ReportTest::registration_;

TEST_F(ReportTest, EvaluateAgainstTruthAndAnotherRun) {
  EvaluateOptions options;
  options.ground_truth = dataset_;
  const Evaluation truth = evaluateRegistration(dir_ / "reg", options);
  ASSERT_TRUE(truth.ground_truth);
  EXPECT_EQ(truth.ground_truth->cameras.size(), 6u);
  EXPECT_LT(truth.ground_truth->rms.position_m_total, 1e-9);
  EXPECT_LT(truth.ground_truth->rms.rotation_deg_total, 1e-6);
  ASSERT_TRUE(truth.reprojection);
  EXPECT_GT(truth.reprojection->total.blobs, 10);
  EXPECT_GT(truth.reprojection->total.rms_px_before, truth.reprojection->total.rms_px_after);
  EXPECT_LT(truth.reprojection->total.rms_px_after, 2.0);  // simulated blob noise

  // Another run: every camera yawed by 1 deg about the world's vertical, one moved up 3 cm
  // (the alignment spreads the 3 cm over all cameras; the yaw survives it exactly).
  Registration other = registration_;
  for (CameraRegistration& c : other.cameras) {
    c.world_from_camera.rotation =
        Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 180, Eigen::Vector3d::UnitZ())) *
        c.world_from_camera.rotation;
  }
  saveRegistration(other, dir_ / "other");
  EvaluateOptions against;
  against.against = dir_ / "other";
  const Evaluation e = evaluateRegistration(dir_ / "reg", against);
  ASSERT_TRUE(e.against);
  EXPECT_NEAR(e.against->rms.roll_pitch_yaw_deg.z(), 1.0, 1e-6);
  EXPECT_LT(e.against->rms.roll_pitch_yaw_deg.head<2>().norm(), 1e-6);
  EXPECT_LT(e.against->rms.position_m_total, 1e-9);

  // Bad inputs name the file.
  try {
    EvaluateOptions bad;
    bad.ground_truth = dir_ / "nothing.csv";
    evaluateRegistration(dir_ / "reg", bad);
    FAIL();
  } catch (const Error& error) {
    EXPECT_NE(std::string(error.what()).find("nothing.csv"), std::string::npos) << error.what();
  }
  EXPECT_THROW(evaluateRegistration(dir_ / "reg", EvaluateOptions{}), Error);
}

TEST_F(ReportTest, HtmlIsSelfContainedAndRendersInChromium) {
  ReportOptions options;
  options.out = dir_ / "report.html";
  options.ground_truth = dataset_;
  options.size = cv::Size(640, 360);
  const ReportSummary summary = writeReport(dataset_, dir_ / "reg", options, ProgressReporter());
  EXPECT_EQ(summary.verdict, Verdict::kOk)
      << (summary.reasons.empty() ? "" : summary.reasons.front());
  EXPECT_GE(summary.pictures, 4);
  std::ifstream in(options.out);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string html = buffer.str();
  EXPECT_NE(html.find("Verdict: ok"), std::string::npos);
  EXPECT_NE(html.find("paper's Table I"), std::string::npos);
  EXPECT_NE(html.find("<td class=l>cam03</td>"), std::string::npos);
  size_t images = 0;
  for (size_t at = html.find("data:image/png;base64,"); at != std::string::npos;
       at = html.find("data:image/png;base64,", at + 1)) {
    ++images;
  }
  EXPECT_EQ(images, static_cast<size_t>(summary.pictures));
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);  // nothing fetched from outside
  EXPECT_EQ(html.find("<script"), std::string::npos);
  // No temporary picture folder left behind.
  for (const auto& entry : fs::directory_iterator(dir_)) {
    EXPECT_EQ(entry.path().filename().string().find(".lookboth-report-"), std::string::npos);
  }

  // A real browser renders it: chromium (scripts/setup.sh installs it) headless to a PNG.
  ASSERT_EQ(std::system("command -v chromium > /dev/null"), 0)
      << "chromium is not installed (scripts/setup.sh installs it)";
  const fs::path png = dir_ / "report.png";
  const std::string command =
      "timeout 120 chromium --headless --no-sandbox --disable-gpu "
      "--hide-scrollbars --user-data-dir=" +
      (dir_ / "chromium-profile").string() +
      " --window-size=1280,1400 --screenshot=" + png.string() + " file://" +
      fs::absolute(options.out).string() + " > " + (dir_ / "chromium.log").string() + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const cv::Mat shot = cv::imread(png.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(shot.empty());
  EXPECT_EQ(shot.size(), cv::Size(1280, 1400));
  int non_white = 0, verdict_green = 0;
  for (int y = 0; y < shot.rows; ++y) {
    for (int x = 0; x < shot.cols; ++x) {
      const cv::Vec3b p = shot.at<cv::Vec3b>(y, x);
      if (p[0] < 240 || p[1] < 240 || p[2] < 240) ++non_white;
      // The verdict banner, #1e8f3a.
      if (std::abs(p[0] - 0x3a) < 12 && std::abs(p[1] - 0x8f) < 12 && std::abs(p[2] - 0x1e) < 12) {
        ++verdict_green;
      }
    }
  }
  EXPECT_GT(non_white, static_cast<int>(shot.total() / 20)) << "the page looks blank";
  EXPECT_GT(verdict_green, 5000) << "the verdict banner is not on the page";
}

// The run time `register` recorded, against the drive it processed.
TEST_F(ReportTest, ShowsTheRunTimeAgainstTheDrive) {
  Registration timed = registration_;
  timed.statistics.seconds_per_stage = {{"joint", 0.75}, {"look_down", 0.25}};
  timed.statistics.seconds_per_step = {{"detect", 12.0}, {"odometry", 8.0}};
  timed.statistics.drive_seconds = 42.0;
  saveRegistration(timed, dir_ / "timed");
  const ReportOptions options = textOnly("timed");
  writeReport(dataset_, dir_ / "timed", options, ProgressReporter());
  EXPECT_NE(readFile(options.out)
                .find("<h2>Run time</h2>\n<p>detect 12.0 s, odometry 8.0 s, the stages "
                      "1.0 s: 21.0 s in all, 0.50x the drive (42.0 s).</p>"),
            std::string::npos);
}

TEST_F(ReportTest, VerdictNamesWhatIsWrong) {
  Registration bad = registration_;
  bad.cameras[1].status = CameraStatus::kSuspect;
  bad.cameras[1].reason = "detections disagree";
  bad.cameras[2].status = CameraStatus::kUnregistered;
  bad.cameras[2].reason = "never detected";
  saveRegistration(bad, dir_ / "bad");
  const ReportOptions options = textOnly("bad");
  const ReportSummary summary = writeReport(dataset_, dir_ / "bad", options, ProgressReporter());
  EXPECT_EQ(summary.verdict, Verdict::kNeedsChecking);
  std::string all;
  for (const auto& r : summary.reasons) all += r + "\n";
  EXPECT_NE(all.find("1 camera(s) not registered"), std::string::npos) << all;
  EXPECT_NE(all.find("1 camera(s) suspect"), std::string::npos) << all;
}

// Against ground truth, a registration whose predicted uncertainty is far
// smaller than its errors is not "ok": 1 cm height errors predicted at 1 mm.
TEST_F(ReportTest, VerdictDistrustsAnUncertaintyTooSmallForTheErrors) {
  auto reasonsWith = [&](double predicted_sigma_m, const std::string& name) {
    Registration reg = registration_;
    for (size_t i = 0; i < reg.cameras.size(); ++i) {
      reg.cameras[i].world_from_camera.translation.z() += (i % 2 ? 0.01 : -0.01);
      reg.cameras[i].aligned_position_covariance =
          Eigen::Matrix3d::Identity() * predicted_sigma_m * predicted_sigma_m;
    }
    saveRegistration(reg, dir_ / name);
    ReportOptions options = textOnly(name);
    options.ground_truth = dataset_;
    std::string all;
    for (const auto& r : writeReport(dataset_, dir_ / name, options, ProgressReporter()).reasons)
      all += r + "\n";
    return all;
  };
  EXPECT_NE(reasonsWith(0.001, "overconfident").find("the predicted uncertainty is too small"),
            std::string::npos);
  EXPECT_EQ(reasonsWith(0.02, "honest").find("the predicted uncertainty"), std::string::npos);
}

TEST(Base64, KnownVectors) {
  const auto b = [](const std::string& s) {
    return base64(std::vector<unsigned char>(s.begin(), s.end()));
  };
  EXPECT_EQ(b(""), "");
  EXPECT_EQ(b("f"), "Zg==");
  EXPECT_EQ(b("fo"), "Zm8=");
  EXPECT_EQ(b("foo"), "Zm9v");
  EXPECT_EQ(b("foobar"), "Zm9vYmFy");
}

// scene.3Dscene: each camera with a covariance as MRPT's pose PDF beside its frustum.
TEST(Scene, CamerasWithACovarianceHaveTheirPosePdf) {
  RegistrationRun run;
  for (int i = 0; i < 2; ++i) {
    CameraRegistration c;
    c.label = "cam0" + std::to_string(i);
    c.status = CameraStatus::kRegistered;
    c.world_from_camera = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(i, 0, 3));
    if (i == 0) c.covariance = Matrix6d::Identity() * 1e-4;
    run.registration.cameras.push_back(c);
  }
  const fs::path file =
      fs::temp_directory_path() / ("scene_" + std::to_string(getpid()) + ".3Dscene");
  writeRegistrationScene(run, file);
  mrpt::opengl::COpenGLScene scene;
  ASSERT_TRUE(scene.loadFromFile(file.string()));
  EXPECT_TRUE(scene.getByName("cam00"));
  EXPECT_TRUE(scene.getByName("cam00 pdf"));
  EXPECT_TRUE(scene.getByName("cam01"));
  EXPECT_FALSE(scene.getByName("cam01 pdf"));
  fs::remove(file);
}

}  // namespace
}  // namespace lookboth::report
