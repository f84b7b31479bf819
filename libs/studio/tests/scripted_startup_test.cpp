// The desktop app's unattended startup, without a window: the order of its
// actions, each asynchronous one waited for, and a mistake in the command
// line said without stopping the rest.
#include "lookboth/studio/scripted_startup.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace lookboth::studio {
namespace {

// Records what the script asks for; an asynchronous action "ends" when the
// test calls finishJob(), as the window's job would.
class RecordingTarget : public ScriptedStartup::Target {
 public:
  std::vector<std::string> calls;
  bool job_running = false;
  bool dataset = false;

  bool hasDataset() const override { return dataset; }
  void simulate(const StartupActions& a) override {
    start("simulate " + a.simulate);
    dataset = true;
  }
  void open(const std::string& d) override {
    start("open " + d);
    dataset = true;
  }
  void loadCalibration(const std::string& c, const std::string& f) override {
    start("calibration " + c + "=" + f);
  }
  int stepIndex(const std::string& name) const override {
    for (int i = 0; i < stepCount(); ++i)
      if (steps[i] == name) return i;
    return -1;
  }
  int stepCount() const override { return 4; }
  std::string stepNames() const override { return "detect, odometry, look_down, joint"; }
  void runThrough(int last) override { start("run through " + std::to_string(last)); }
  void error(const std::string& m) override { calls.push_back("error " + m); }
  void show(int overlay, const std::string& camera, int frame) override {
    calls.push_back("show " + std::to_string(overlay) + " '" + camera + "' " +
                    std::to_string(frame));
  }
  void exportRegistration(const std::string& d) override { calls.push_back("registration " + d); }
  void alignToFloor(const std::string& d) override { calls.push_back("floor " + d); }
  void checkAgainst(const std::string& d) override { calls.push_back("check " + d); }
  void updateRecord(const std::string& d, const std::string& out) override {
    start("update " + d + " " + out);
  }
  void exportFormats(const std::string& f, const std::string& d) override {
    calls.push_back("export " + f + " " + d);
  }
  void exportReport(const std::string& p) override { start("report " + p); }
  void finish(const std::string& shot, bool exit) override {
    calls.push_back("finish '" + shot + "'" + (exit ? " exit" : ""));
  }

 private:
  void start(const std::string& call) {
    EXPECT_FALSE(job_running) << call << " started while a job runs";
    job_running = true;
    calls.push_back(call);
  }
  const char* steps[4] = {"detect", "odometry", "look_down", "joint"};
};

// Runs the script as the event loop would: next() again each time a job ends.
std::vector<std::string> runScript(const StartupActions& actions, RecordingTarget& target) {
  ScriptedStartup script(actions, target);
  script.next();
  for (int guard = 0; target.job_running && guard < 100; ++guard) {
    target.job_running = false;
    script.next();
  }
  EXPECT_TRUE(script.done());
  return target.calls;
}

TEST(ScriptedStartup, EveryActionInOrderEachAfterTheOneBefore) {
  StartupActions a;
  a.simulate = "small";
  a.calibrations = {{"cam00", "a.yaml"}, {"cam01", "b.yaml"}};
  a.run_until = "look_down";
  a.overlay = "after";
  a.select = "cam03";
  a.frame = 12;
  a.export_registration = "reg";
  a.align_floor = "reg_floor";
  a.check_against = "record";
  a.update_record = "record";
  a.update_out = "updated";
  a.export_formats = "colmap,ros";
  a.export_formats_dir = "exports";
  a.export_report = "r.html";
  a.screenshot = "s.png";
  a.exit = true;
  RecordingTarget target;
  const std::vector<std::string> expected = {"simulate small",
                                             "calibration cam00=a.yaml",
                                             "calibration cam01=b.yaml",
                                             "run through 2",
                                             "update record updated",
                                             "show 1 'cam03' 12",
                                             "registration reg",
                                             "floor reg_floor",
                                             "check record",
                                             "export colmap,ros exports",
                                             "report r.html",
                                             "finish 's.png' exit"};
  EXPECT_EQ(runScript(a, target), expected);
}

TEST(ScriptedStartup, NothingAskedShowsTheViewsAndWaitsForAPerson) {
  RecordingTarget target;
  const std::vector<std::string> expected = {"show 0 '' -1"};
  EXPECT_EQ(runScript(StartupActions{}, target), expected);
}

TEST(ScriptedStartup, AnUnknownStepIsSaidAndTheRestStillRuns) {
  StartupActions a;
  a.open = "d.rawlog";
  a.run_until = "look_sideways";
  a.overlay = "before";
  a.exit = true;
  RecordingTarget target;
  const std::vector<std::string> expected = {
      "open d.rawlog",
      "error --run-until: no step 'look_sideways' (steps: detect, odometry, look_down, joint)",
      "show 2 '' -1", "finish '' exit"};
  EXPECT_EQ(runScript(a, target), expected);
}

TEST(ScriptedStartup, RunAllRunsEveryStepAndNothingRunsWithoutADataset) {
  StartupActions a;
  a.open = "d.rawlog";
  a.run_all = true;
  RecordingTarget target;
  EXPECT_EQ(runScript(a, target)[1], "run through 3");

  // No dataset (the open failed): no calibration and no run are attempted.
  StartupActions b;
  b.run_all = true;
  b.calibrations = {{"cam00", "a.yaml"}};
  RecordingTarget empty;
  const std::vector<std::string> expected = {"show 0 '' -1"};
  EXPECT_EQ(runScript(b, empty), expected);
}

TEST(ScriptedStartup, OverlayNames) {
  EXPECT_EQ(overlayMode("both"), 0);
  EXPECT_EQ(overlayMode(""), 0);
  EXPECT_EQ(overlayMode("after"), 1);
  EXPECT_EQ(overlayMode("before"), 2);
}

}  // namespace
}  // namespace lookboth::studio
