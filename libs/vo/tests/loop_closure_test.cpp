// The odometry end to end on a rendered aisle (generated once here): a loop
// found when a place is revisited in the opposite direction, what it brings,
// and a second map segment (after a loss relocalisation cannot fix) joined
// to the first by a later loop.
#include "lookboth/vo/odometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>

#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/vo/run.h"
#include "vo_test_scenes.h"

namespace lookboth::vo {
namespace {

using scenes::groundTruth;
using scenes::renderedScene;
using scenes::Scene;

// An aisle driven out along one lane and back along the other, 1.2 m apart:
// the second pass sees the ceiling rotated by 180 deg about the optical axis.
Scene aisle() {
  Scene scene;
  scene.name = "aisle";
  scene.loop = "[[3, 3], [8, 3], [8, 4.2], [3, 4.2]]";
  scene.wait_s = 0.5;
  return scene;
}

TEST(OdometryTest, LoopClosedWhenRevisitedInTheOppositeDirection) {
  const auto dataset = renderedScene(aisle());
  const Trajectory truth = groundTruth(dataset);
  OdometryRunOptions options;
  options.dataset = dataset;
  options.write_dataset = false;
  const OdometryRunSummary with_loops = runOdometry(options, ProgressReporter());
  const OdometryStatistics& s = with_loops.result.statistics;
  ASSERT_GE(s.loop_closures, 1);
  // The loop joins the two lanes: keyframes close in space, opposite in heading.
  bool opposite = false;
  for (const auto& [t_current, t_old] : s.loops) {
    const auto a = truth.interpolate(t_current, 0);
    const auto b = truth.interpolate(t_old, 0);
    ASSERT_TRUE(a.ok() && b.ok());
    const double distance = (a.world_from_body.translation - b.world_from_body.translation).norm();
    const double turn =
        rotationAngleBetween(a.world_from_body.rotation, b.world_from_body.rotation);
    EXPECT_LT(distance, 2.5);
    opposite = opposite || turn > 2.5;  // rad: ~180 deg about the vertical
  }
  EXPECT_TRUE(opposite);
  ASSERT_TRUE(with_loops.ate);
  options.odometry.loop_closure = false;
  const OdometryRunSummary without = runOdometry(options, ProgressReporter());
  ASSERT_TRUE(without.ate);
  EXPECT_EQ(without.result.statistics.loop_closures, 0);
  EXPECT_LT(with_loops.ate->rmse, without.ate->rmse);
}

// The global adjustment on an observation budget a third of what the one
// problem holds: the problems stay within it (up to whole landmarks), and the
// loop still brings the error down.
TEST(OdometryTest, ObservationBudgetBoundsTheGlobalAdjustment) {
  const auto dataset = renderedScene(aisle());
  OdometryRunOptions options;
  options.dataset = dataset;
  options.write_dataset = false;
  options.odometry.global_max_observations = 0;
  const OdometryRunSummary all = runOdometry(options, ProgressReporter());
  const OdometryStatistics& a = all.result.statistics;
  ASSERT_GE(a.loop_closures, 1);
  ASSERT_TRUE(all.ate);
  options.odometry.global_max_observations = static_cast<int>(a.global_largest_observations / 3);
  options.odometry.global_min_observations_per_keyframe = 10;
  const OdometryRunSummary budget = runOdometry(options, ProgressReporter());
  const OdometryStatistics& b = budget.result.statistics;
  ASSERT_TRUE(budget.ate);
  options.odometry.loop_closure = false;
  const OdometryRunSummary without = runOdometry(options, ProgressReporter());
  ASSERT_TRUE(without.ate);
  std::printf(
      "one problem: %lld observations, ATE %.3f %%; budget %d: %lld, ATE %.3f %%; "
      "without loop closure %.3f %%\n",
      static_cast<long long>(a.global_largest_observations), all.ate->percent(),
      options.odometry.global_max_observations,
      static_cast<long long>(b.global_largest_observations), budget.ate->percent(),
      without.ate->percent());
  EXPECT_GE(b.loop_closures, 1);
  EXPECT_LT(b.global_largest_observations, 1.5 * options.odometry.global_max_observations);
  EXPECT_EQ(b.global_largest_keyframes, b.keyframes);
  EXPECT_LT(budget.ate->rmse, without.ate->rmse);
}

// Blank frames (a lens cap) for longer than relocalisation is tried: the
// odometry starts a second segment after them; on the way back along the
// other lane a loop to a keyframe of the first segment joins the two into
// one map, in one frame and at one scale.
TEST(OdometryTest, NewSegmentIsJoinedToTheOldMapByALaterLoop) {
  const auto dataset = renderedScene(aisle());
  const Trajectory truth = groundTruth(dataset);
  auto reader = DatasetReader::open(dataset);
  const Camera camera = *reader->manifest().fisheye()->camera;
  const OdometryOptions options;
  const int blank_frames = options.max_lost_frames + 5;
  VisualOdometry odometry(camera, options);
  const int factor = VisualOdometry::downscaleFactor(camera.width(), options);
  int index = 0, first_blank = -1;
  TimeNs blank_begin = 0, blank_end = 0;
  while (auto record = reader->next()) {
    const auto* frame = std::get_if<ImageFrame>(&*record);
    if (!frame || frame->sensor != "fisheye") continue;
    cv::Mat image = cv::imread(frame->image_file.string(), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(image.empty());
    image = VisualOdometry::prepareImage(image, factor);
    if (first_blank < 0 && odometry.statistics().keyframes >= 15) {
      first_blank = index;
      blank_begin = frame->t;
    }
    if (first_blank >= 0 && index >= first_blank && index < first_blank + blank_frames) {
      image.setTo(cv::Scalar(128));
      blank_end = frame->t;
    }
    odometry.processFrame(frame->t, image);
    ++index;
    // Once a loop has joined the segments, the rest of the clip adds nothing.
    bool joined = false;
    for (const auto& [t_current, t_old] : odometry.statistics().loops)
      joined |= first_blank >= 0 && t_old < blank_begin && t_current > blank_end;
    if (joined) break;
  }
  ASSERT_GE(first_blank, 0);
  const OdometryResult result = odometry.finish();
  const OdometryStatistics& s = result.statistics;
  EXPECT_GE(s.tracking_losses, 1);
  EXPECT_EQ(s.segments, 2) << "relocalisation should not have recovered from blank frames";
  EXPECT_EQ(s.segments_at_end, 1) << "the second segment was not joined";
  // A loop from after the blank frames to before them.
  bool joined = false;
  for (const auto& [t_current, t_old] : s.loops)
    joined |= t_old < blank_begin && t_current > blank_end;
  EXPECT_TRUE(joined);
  // One frame and one scale for both segments: a single Sim(3) aligns the
  // whole trajectory to the truth.
  const auto ate = absoluteTrajectoryError(result.trajectory, truth);
  ASSERT_TRUE(ate);
  EXPECT_LT(ate->percent(), 1.0) << "ATE " << ate->rmse << " m over " << ate->path_length << " m";
}

}  // namespace
}  // namespace lookboth::vo
