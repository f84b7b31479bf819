// writeSnapshots() on simulated data: the pictures exist with the requested
// size, the overlays sit at the projected positions (computed here
// independently of the drawing code), the 3-D overview is not empty.
//
// The registration here is made from the simulator's ground truth
// (truth_registration.h), so the test does not depend on the estimator.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <random>

#include "lookboth/core/error.h"
#include "lookboth/geometry/tum.h"
#include "lookboth/pipeline/registration_controller.h"
#include "lookboth/report/draw.h"
#include "lookboth/report/overview.h"
#include "lookboth/report/snapshot.h"
#include "lookboth/sim/simulate.h"
#include "truth_registration.h"

namespace lookboth::report {
namespace {

namespace fs = std::filesystem;

struct Simulated {
  Manifest manifest;
  RegistrationView view;
};

/// The registration view of the truth-made registration (through
/// viewOfRegistration, the bridge from libs/calib): final = truth, before =
/// truth + (0.15, -0.1, 0.05) m.
Simulated viewFromTruth(const fs::path& dataset) {
  Simulated s;
  s.manifest = DatasetReader::open(dataset)->manifest();
  s.view = viewOfRegistration(
      testing::registrationFromTruth(dataset, Eigen::Vector3d(0.15, -0.1, 0.05)), "truth");
  return s;
}

class SnapshotTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_snapshot_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!std::getenv("LOOKBOTH_KEEP_TEST_OUTPUT")) fs::remove_all(dir_);
  }

  fs::path simulateSmall(bool detections_only, double seconds) {
    sim::SimulateOptions options;
    options.scenario = "small";
    options.out = dir_ / "small.rawlog";
    options.detections_only = detections_only;
    options.max_duration_s = seconds;
    options.threads = 2;
    sim::simulate(options, ProgressReporter());
    return options.out;
  }
  fs::path dir_;
};

bool colourNear(const cv::Vec3b& pixel, const cv::Scalar& colour, int tolerance = 40) {
  for (int c = 0; c < 3; ++c) {
    if (std::abs(pixel[c] - static_cast<int>(colour[c])) > tolerance) return false;
  }
  return true;
}

cv::Point2d toOutput(const Eigen::Vector2d& p, cv::Size in, cv::Size out) {
  return {(p.x() + 0.5) * out.width / in.width - 0.5, (p.y() + 0.5) * out.height / in.height - 0.5};
}

/// Checks every fisheye picture: the pixel at each association's "after"
/// projection is the after colour; at "before" (when far from every "after")
/// the before colour.
void expectOverlaysAtProjections(const SnapshotResult& result, const RegistrationView& view,
                                 cv::Size fisheye_size, int* checked) {
  for (const SnapshotPicture& picture : result.pictures) {
    if (picture.kind != "fisheye_check") continue;
    const cv::Mat image = cv::imread(picture.file.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(image.empty()) << picture.file;
    std::vector<cv::Point2d> afters;
    for (const ReprojectionRow& row : view.blob_associations) {
      if (row.t == picture.t && row.after)
        afters.push_back(toOutput(*row.after, fisheye_size, image.size()));
    }
    for (const cv::Point2d& at : afters) {
      const cv::Point p(static_cast<int>(std::lround(at.x)), static_cast<int>(std::lround(at.y)));
      EXPECT_TRUE(colourNear(image.at<cv::Vec3b>(p), colours::kAfter))
          << picture.file << " at " << p << ": " << image.at<cv::Vec3b>(p);
      ++*checked;
    }
    for (const ReprojectionRow& row : view.blob_associations) {
      if (row.t != picture.t || !row.before) continue;
      const cv::Point2d at = toOutput(*row.before, fisheye_size, image.size());
      bool near_after = false;
      for (const cv::Point2d& a : afters) near_after |= cv::norm(a - at) < 12;
      if (near_after) continue;
      const cv::Point p(static_cast<int>(std::lround(at.x)), static_cast<int>(std::lround(at.y)));
      EXPECT_TRUE(colourNear(image.at<cv::Vec3b>(p), colours::kBefore))
          << picture.file << " at " << p << ": " << image.at<cv::Vec3b>(p);
      ++*checked;
    }
  }
}

TEST_F(SnapshotTest, DetectionsOnlySmallScenario) {
  const fs::path dataset = simulateSmall(true, 12);
  const Simulated s = viewFromTruth(dataset);
  ASSERT_FALSE(s.view.blob_associations.empty());
  SnapshotOptions options;
  options.out = dir_ / "pictures";
  options.size = cv::Size(800, 450);
  options.references.push_back(
      {"ground_truth",
       CameraPoseSet{"ground truth", s.manifest.ground_truth.world_from_camera, {}, {}}});
  const SnapshotResult result = writeSnapshots(dataset, s.view, options, ProgressReporter());

  std::map<std::string, int> kinds;
  for (const SnapshotPicture& picture : result.pictures) {
    ++kinds[picture.kind];
    const cv::Mat image = cv::imread(picture.file.string(), cv::IMREAD_COLOR);
    ASSERT_FALSE(image.empty()) << picture.file;
    EXPECT_EQ(image.size(), cv::Size(800, 450)) << picture.file;
  }
  EXPECT_GE(kinds["fisheye_check"], 3);
  EXPECT_LE(kinds["fisheye_check"], options.auto_frames);
  EXPECT_GE(kinds["env_view"], 1);
  EXPECT_EQ(kinds["overview_3d"], 1);
  EXPECT_EQ(kinds["compare"], 1);
  ASSERT_EQ(result.comparisons.size(), 1u);
  EXPECT_LT(result.comparisons[0].rms.position_m_total, 1e-9);

  int checked = 0;
  expectOverlaysAtProjections(result, s.view, {640, 360}, &checked);
  EXPECT_GE(checked, 6);

  // Env views: the predicted marker centre is drawn in its colour at the
  // truth's projection of the marker.
  for (const SnapshotPicture& picture : result.pictures) {
    if (picture.kind != "env_view") continue;
    bool found = false;
    for (const OverlayMark& mark : picture.marks) found |= mark.kind == "marker_predicted";
    EXPECT_TRUE(found) << picture.file;
  }

  // The 3-D overview is not empty: many non-white pixels, and camera blue among them.
  for (const SnapshotPicture& picture : result.pictures) {
    if (picture.kind != "overview_3d") continue;
    const cv::Mat image = cv::imread(picture.file.string(), cv::IMREAD_COLOR);
    int drawn = 0, camera_blue = 0;
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
        if (p != cv::Vec3b(255, 255, 255)) ++drawn;
        if (colourNear(p,
                       cv::Scalar(OverviewColours::kCamera[2], OverviewColours::kCamera[1],
                                  OverviewColours::kCamera[0]),
                       50)) {
          ++camera_blue;
        }
      }
    }
    EXPECT_GT(drawn, image.total() / 50) << "overview nearly blank";
    EXPECT_GT(camera_blue, 100) << "no camera drawn in the overview";
  }
}

TEST_F(SnapshotTest, RenderedFramesByIndexAtNativeSize) {
  const fs::path dataset = simulateSmall(false, 3);
  const Simulated s = viewFromTruth(dataset);
  SnapshotOptions options;
  options.out = dir_ / "pictures";
  options.frames = FrameSelection::parse("0,5,10");
  options.overview = false;
  const SnapshotResult result = writeSnapshots(dataset, s.view, options, ProgressReporter());
  int fisheye = 0;
  for (const SnapshotPicture& picture : result.pictures) {
    if (picture.kind != "fisheye_check") continue;
    ++fisheye;
    const cv::Mat image = cv::imread(picture.file.string(), cv::IMREAD_COLOR);
    EXPECT_EQ(image.size(), cv::Size(640, 360));
    EXPECT_NE(picture.file.filename().string().find("fisheye_check_f00"), std::string::npos);
  }
  EXPECT_EQ(fisheye, 3);
  int checked = 0;
  expectOverlaysAtProjections(result, s.view, {640, 360}, &checked);
  EXPECT_GE(checked, 3);
}

// The estimator's own output (libs/calib's pipeline on the whole `small`
// scenario, detections only, metric odometry trajectory): the overlays sit at
// the positions of its blob_associations.
TEST_F(SnapshotTest, RealRegistrationOfSmall) {
  const fs::path dataset = simulateSmall(true, 0);
  RegisterOptions register_options;
  register_options.dataset = dataset;
  register_options.mode = TrajectoryMode::kMetric;
  const RegistrationController controller(loadRegistrationConfig(std::nullopt));
  const RegistrationRun run = controller.run(
      loadRegistrationInput(register_options, ProgressReporter()), ProgressReporter());
  ASSERT_GE(run.registration.registeredCount(), 4);
  const RegistrationView view = viewOfRegistration(run.registration, "registration");
  ASSERT_FALSE(view.blob_associations.empty());
  ASSERT_FALSE(view.world_from_camera_before.empty());
  SnapshotOptions options;
  options.out = dir_ / "pictures";
  options.size = cv::Size(960, 540);
  options.overview = false;
  const SnapshotResult result = writeSnapshots(dataset, view, options, ProgressReporter());
  int checked = 0;
  expectOverlaysAtProjections(result, view, {640, 360}, &checked);
  EXPECT_GE(checked, 10);
}

// A dataset with a trajectory and the same before loop closure gets the
// figure-8 picture.
TEST_F(SnapshotTest, LoopClosurePicture) {
  sim::SimulateOptions sim_options;
  sim_options.scenario = "small";
  sim_options.out = dir_ / "small_folder";
  sim_options.kind = DatasetKind::kFolder;
  sim_options.detections_only = true;
  sim_options.max_duration_s = 10;
  sim::simulate(sim_options, ProgressReporter());
  const Simulated s = viewFromTruth(sim_options.out);
  Trajectory closed, open;
  for (const StampedPose& p : s.view.trajectory.samples()) {
    closed.append(p.t, p.world_from_body);
    Rigid3d drifted = p.world_from_body;
    drifted.translation.x() += 0.1 * drifted.translation.y();  // a drift growing with y
    open.append(p.t, drifted);
  }
  fs::create_directories(sim_options.out / "trajectories");
  writeTumFile(sim_options.out / "trajectories" / "vo.tum", closed);
  writeTumFile(sim_options.out / "trajectories" / "vo_before_loop_closure.tum", open);
  SnapshotOptions options;
  options.out = dir_ / "pictures";
  options.overview = false;
  options.max_env_views = 0;
  options.auto_frames = 1;
  const SnapshotResult result =
      writeSnapshots(sim_options.out, s.view, options, ProgressReporter());
  bool found = false;
  for (const SnapshotPicture& picture : result.pictures) {
    if (picture.kind != "loop_closure") continue;
    found = true;
    EXPECT_EQ(picture.file.filename(), "trajectory_loop_closure_vo.png");
    const cv::Mat image = cv::imread(picture.file.string(), cv::IMREAD_COLOR);
    EXPECT_EQ(image.size(), cv::Size(1280, 720));
    int red = 0, green = 0;
    for (int y = 0; y < image.rows; ++y) {
      for (int x = 0; x < image.cols; ++x) {
        const cv::Vec3b p = image.at<cv::Vec3b>(y, x);
        red += colourNear(p, colours::kBefore, 30);
        green += colourNear(p, cv::Scalar(0, 160, 0), 30);
      }
    }
    EXPECT_GT(red, 300);
    EXPECT_GT(green, 300);
  }
  EXPECT_TRUE(found);
}

TEST(FrameSelection, ParsesAndRefuses) {
  EXPECT_EQ(FrameSelection::parse("auto").mode, FrameSelection::Mode::kAuto);
  const FrameSelection indices = FrameSelection::parse("3,10,42");
  EXPECT_EQ(indices.indices, (std::vector<int>{3, 10, 42}));
  const FrameSelection range = FrameSelection::parse("1.5:4");
  EXPECT_EQ(range.mode, FrameSelection::Mode::kTimeRange);
  EXPECT_DOUBLE_EQ(range.t1_s, 4);
  EXPECT_THROW(FrameSelection::parse("4:1"), Error);
  EXPECT_THROW(FrameSelection::parse("a,b"), Error);
  EXPECT_EQ(parseSize("800x450"), cv::Size(800, 450));
  EXPECT_THROW(parseSize("800"), Error);
  EXPECT_THROW(parseSize("10x10"), Error);
}

}  // namespace
}  // namespace lookboth::report
