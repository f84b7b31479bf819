// The desktop app's pipeline, one step per call, without a window: the
// same controller as `lookboth register`, each stage's registration handed
// back, the registration directory written after the last stage.
#include "lookboth/studio/step_runner.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "lookboth/core/error.h"
#include "lookboth/pipeline/registration_controller.h"
#include "lookboth/sim/simulate.h"
#include "lookboth/studio/pipeline_steps.h"

namespace lookboth::studio {
namespace {

namespace fs = std::filesystem;

class StepRunnerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_step_runner_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    sim::SimulateOptions sim;
    sim.scenario = "small";
    sim.out = dir_ / "small.rawlog";
    sim.detections_only = true;
    sim.max_duration_s = 20;
    sim::simulate(sim, ProgressReporter());
    options_.dataset = sim.out;
    options_.out = dir_ / "registration";
    options_.overwrite = true;
    options_.mode = TrajectoryMode::kMetric;
    options_.trajectory_label = "odometry";
    steps_ = PipelineSteps(loadRegistrationConfig(std::nullopt).pipeline);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  FullPipelineOptions options_;
  PipelineSteps steps_;
};

TEST_F(StepRunnerTest, EachStepInTurnThenTheRegistrationWritten) {
  ASSERT_GT(steps_.size(), 3u);
  StepRunner runner(options_);
  // Detections only, a metric trajectory: nothing to detect, no odometry to run.
  for (int step = 0; step < PipelineSteps::kPreparationSteps; ++step) {
    const StepResult r = runner.run(step, steps_[static_cast<size_t>(step)].name, {});
    EXPECT_FALSE(r.outcome.ran) << r.outcome.summary;
    EXPECT_EQ(r.index, nullptr);
    EXPECT_EQ(r.registration, nullptr);
  }
  const int last = static_cast<int>(steps_.size()) - 1;
  for (int step = PipelineSteps::kPreparationSteps; step <= last; ++step) {
    const std::string& name = steps_[static_cast<size_t>(step)].name;
    const StepResult r = runner.run(step, name, {});
    EXPECT_TRUE(r.outcome.ran);
    EXPECT_EQ(r.outcome.summary.rfind(name + ": ", 0), 0u) << r.outcome.summary;
    ASSERT_NE(r.registration, nullptr);
    EXPECT_EQ(r.written, step == last);
    EXPECT_EQ(fs::exists(options_.out / "cameras.csv"), step == last);
    if (step == last) {
      EXPECT_GT(r.registration->registeredCount(), 0);
      EXPECT_FALSE(r.rays.empty());
      EXPECT_NE(r.outcome.summary.find("written to " + options_.out.string()), std::string::npos);
    }
  }
}

TEST_F(StepRunnerTest, AStepAfterOthersRunsThemFirstAndAWrongNameIsAnError) {
  const int first_stage = PipelineSteps::kPreparationSteps;
  const std::string& name = steps_[static_cast<size_t>(first_stage)].name;
  {
    StepRunner runner(options_);
    const StepResult r = runner.run(first_stage, name, {});
    EXPECT_TRUE(r.outcome.ran);
    ASSERT_NE(r.registration, nullptr);
  }
  StepRunner runner(options_);
  EXPECT_THROW(runner.run(first_stage, "look_sideways", {}), Error);
  StepRunner other(options_);
  EXPECT_THROW(other.run(-1, "detect", {}), Error);
}

TEST(StepTitles, EveryStepHasATitle) {
  EXPECT_EQ(stepTitle("look_down"), "Look down (camera poses)");
  EXPECT_EQ(stepTitle("my_stage"), "my_stage");
}

}  // namespace
}  // namespace lookboth::studio
