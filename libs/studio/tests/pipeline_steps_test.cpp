// The desktop app's step sequencing without a window: which step may run,
// what a finished or skipped step records, and what a reset keeps.
#include "lookboth/studio/pipeline_steps.h"

#include <gtest/gtest.h>

namespace lookboth::studio {
namespace {

TEST(PipelineSteps, DetectAndOdometryThenTheStagesOneAtATime) {
  PipelineSteps steps({"associate", "look_down", "joint"});
  ASSERT_EQ(steps.size(), 5u);
  EXPECT_EQ(steps.names(), "detect, odometry, associate, look_down, joint");
  EXPECT_EQ(steps.firstPending(), 0);
  EXPECT_FALSE(steps.isStage(1));
  EXPECT_TRUE(steps.isStage(2));
  EXPECT_FALSE(steps.isStage(5));
  EXPECT_EQ(steps.index("look_down"), 3);
  EXPECT_EQ(steps.index("output"), -1);

  steps.finish(0, false, "detect: skipped (detections present)");
  EXPECT_EQ(steps[0].state, PipelineSteps::State::kSkipped);
  EXPECT_EQ(steps.firstPending(), 1);  // a skipped step counts as ended
  steps.finish(1, true, "odometry: 162 poses");
  steps.finish(2, true, "associate: 137 of 209");
  EXPECT_EQ(steps.firstPending(), 3);
  EXPECT_FALSE(steps.allDone());
  steps.finish(3, true, "");
  steps.finish(4, true, "");
  EXPECT_TRUE(steps.allDone());
  EXPECT_EQ(steps.firstPending(), -1);
}

TEST(PipelineSteps, AResetKeepsDetectionAndOdometryOrNothing) {
  PipelineSteps steps({"associate", "joint"});
  for (int i = 0; i < 4; ++i) steps.finish(i, true, "ran");
  steps.reset(true);  // a stage failed, or "run again"
  EXPECT_EQ(steps[0].state, PipelineSteps::State::kDone);
  EXPECT_EQ(steps[1].note, "ran");
  EXPECT_EQ(steps[2].state, PipelineSteps::State::kPending);
  EXPECT_TRUE(steps[3].note.empty());
  EXPECT_EQ(steps.firstPending(), 2);
  steps.reset(false);  // another dataset
  EXPECT_EQ(steps.firstPending(), 0);
  EXPECT_THROW(steps.finish(9, true, ""), std::out_of_range);
}

}  // namespace
}  // namespace lookboth::studio
