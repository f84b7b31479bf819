// The controller end to end on simulated detections-only datasets (small,
// faults, revisit, and faults with seed 6, generated here), configuration
// errors, and the output directory.
#include <gtest/gtest.h>
#include <unistd.h>

#include <mrpt/opengl/COpenGLScene.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "lookboth/calib/builtin_stages.h"
#include "lookboth/core/error.h"
#include "lookboth/core/test_seed.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/pipeline/full_pipeline.h"
#include "lookboth/pipeline/registration_controller.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/simulate.h"
#include "synthetic.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

// The built-in scenario `name` with its seed (world, cameras, path) and its
// noise drawn from testSeed(seed) (later_drive.noise_seed): under a test seed
// offset, the same facility with another realisation of every random error.
// Without an offset, the built-in scenario itself.
std::string scenarioWithTestNoise(const std::string& name, std::uint32_t seed,
                                  const fs::path& dir) {
  if (testSeed(seed) == seed) return name;
  std::ifstream in(sim::builtinScenarioDirectory() / (name + ".yaml"));
  std::stringstream yaml;
  yaml << in.rdbuf();
  std::string text = yaml.str();
  // `faults`' clock jump on a random camera would follow the noise seed: the
  // tests expect it on cam00, where the scenario's seed (13) puts it.
  const std::string random_node = "node: random";
  if (const auto at = text.find(random_node); at != std::string::npos) {
    text.replace(at, random_node.size(), "node: cam00");
  }
  text += "\nlater_drive:\n  noise_seed: " + std::to_string(testSeed(seed)) + "\n";
  const fs::path file = dir / (name + "_noise_" + std::to_string(seed) + ".yaml");
  std::ofstream(file) << text;
  return file.string();
}

class PipelineTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() /
                        ("lookboth_calib_pipeline_" + std::to_string(::getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
    for (const char* scenario : {"small", "faults", "revisit", "faults6"}) {
      sim::SimulateOptions options;
      const std::string name = std::string(scenario) == "faults6" ? "faults" : scenario;
      if (std::string(scenario) == "faults6") options.seed = 6;  // `faults` with seed 6
      options.scenario =
          scenarioWithTestNoise(name, options.seed.value_or(sim::loadScenario(name).seed), *dir_);
      options.detections_only = true;
      options.out = *dir_ / scenario / (std::string(scenario) + ".rawlog");
      fs::create_directories(options.out.parent_path());
      sim::simulate(options, ProgressReporter());
    }
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  static fs::path dataset(const std::string& scenario) {
    return *dir_ / scenario / (scenario + ".rawlog");
  }
  static RegistrationRun registerDataset(const std::string& scenario, TrajectoryMode mode,
                                         const std::string& label,
                                         RegistrationInput* input_out = nullptr,
                                         const std::optional<fs::path>& config = std::nullopt) {
    RegisterOptions options;
    options.dataset = dataset(scenario);
    options.mode = mode;
    options.trajectory_label = label;
    RegistrationInput input = loadRegistrationInput(options, ProgressReporter());
    if (input_out) *input_out = input;
    return runRegistration(std::move(input), config);
  }
  // The controller with the default configuration, or `config` over it.
  static RegistrationRun runRegistration(RegistrationInput input,
                                         const std::optional<fs::path>& config = std::nullopt) {
    const RegistrationController controller(loadRegistrationConfig(config));
    return controller.run(std::move(input), ProgressReporter());
  }
  // share/lookboth/config/paper.yaml (the paper's stages) or the default.
  static std::optional<fs::path> paperConfigOr(bool paper) {
    if (!paper) return std::nullopt;
    return fs::path(LOOKBOTH_SHARE_DIR) / "config" / "paper.yaml";
  }
  // The dataset's ground-truth trajectory made visual odometry (scale 0.45,
  // 1 mm/sqrt(m), 0.02 deg/sqrt(m)); `world_from_vo` maps its frame to the truth's.
  static RegistrationInput withSynthesisedOdometry(const std::string& scenario,
                                                   Rigid3d* world_from_vo) {
    RegisterOptions options;
    options.dataset = dataset(scenario);
    options.mode = TrajectoryMode::kMetric;
    options.trajectory_label = "ground_truth";
    RegistrationInput input = loadRegistrationInput(options, ProgressReporter());
    std::vector<StampedPose> vo = input.trajectory.samples();
    *world_from_vo = testing::makeVisualOdometry(vo, 0.45, 0.001, 0.02, testSeed(3));
    input.trajectory = Trajectory(vo);
    input.mode = TrajectoryMode::kVisual;
    return input;
  }
  // Registers `scenario` with synthesised odometry and checks the scale
  // (0.45 within 1 %), the cameras compared and the RMSEs in the known frame.
  static void expectSynthesisedOdometryRegisters(const std::string& scenario, int cameras,
                                                 double max_position_m, double max_rotation_deg) {
    Rigid3d world_from_vo;
    RegistrationInput input = withSynthesisedOdometry(scenario, &world_from_vo);
    const auto truth = input.manifest.ground_truth.world_from_camera;
    const RegistrationRun run = runRegistration(std::move(input));
    EXPECT_NEAR(run.registration.scale, 0.45, 0.45 * 0.01);
    const auto a = testing::accuracyAgainst(run.registration, truth, world_from_vo);
    EXPECT_EQ(a.compared, cameras);
    EXPECT_LT(a.position_rmse_m, max_position_m);
    EXPECT_LT(a.rotation_rmse_deg, max_rotation_deg);
  }
  static fs::path* dir_;
};
fs::path* PipelineTest::dir_ = nullptr;

TEST_F(PipelineTest, SmallMetricGroundTruthTrajectory) {
  RegistrationInput input;
  const RegistrationRun run =
      registerDataset("small", TrajectoryMode::kMetric, "ground_truth", &input);
  const Registration& r = run.registration;
  EXPECT_EQ(r.registeredCount(), 6);
  EXPECT_EQ(r.pipeline, (std::vector<std::string>{"associate", "motion_calibration", "look_down",
                                                  "look_up", "joint"}));
  const auto a = testing::accuracyAgainst(r, input.manifest.ground_truth.world_from_camera);
  EXPECT_EQ(a.compared, 6);
  // small: 640x360 cameras, 18 px markers (tilt noise ~17 deg per detection).
  EXPECT_LT(a.position_rmse_m, 0.01);
  EXPECT_LT(a.rotation_rmse_deg, 4.0);
  ASSERT_TRUE(r.reprojection);
  EXPECT_LT(r.reprojection->rms_px_after, r.reprojection->rms_px_before);
  EXPECT_LT(r.reprojection->rms_px_after, 2.5);  // blob noise 1.2 px per axis
  EXPECT_FALSE(r.fisheye_from_marker_determined[2]) << r.observability.message;
  EXPECT_FALSE(run.rays.empty());
}

TEST_F(PipelineTest, SmallMetricWheelOdometry) {
  RegistrationInput input;
  const RegistrationRun run = registerDataset("small", TrajectoryMode::kMetric, "odometry", &input);
  const auto a =
      testing::accuracyAgainst(run.registration, input.manifest.ground_truth.world_from_camera);
  EXPECT_EQ(a.compared, 6);
  EXPECT_LT(a.position_rmse_m, 0.05);
  EXPECT_LT(a.rotation_rmse_deg, 4.0);
  EXPECT_EQ(run.registration.scale, 1.0);
}

TEST_F(PipelineTest, SmallVisualSynthesisedOdometry) {
  // small's 18 px markers have ~17 deg of tilt noise per detection (doc/benchmarks.md).
  expectSynthesisedOdometryRegisters("small", 6, 0.04, 3.0);
}

// small's 18 px markers give each detection ~17 deg of tilt noise, so each
// detection's own camera pose scatters by metres at 3 m: the clock search of
// a camera whose clock is off must put the detections on a rigid path with
// one shared rotation (before, it chose the edge of its range, -500 ms, and
// cam03 ended suspect 25 ms off and 13 mm away).
TEST_F(PipelineTest, SmallVisualCameraClockOff150ms) {
  Rigid3d world_from_vo;
  RegistrationInput input = withSynthesisedOdometry("small", &world_from_vo);
  const TimeNs shift = 150'000'000;
  for (MarkerObservation& m : input.markers) {
    if (m.camera == "cam03") m.t += shift;
  }
  const auto truth = input.manifest.ground_truth.world_from_camera;
  const TimeNs true_offset = input.manifest.ground_truth.clock_offset.at("cam03") + shift;
  const RegistrationRun run = runRegistration(std::move(input));
  const CameraRegistration* c = run.registration.findCamera("cam03");
  ASSERT_TRUE(c && c->clock_offset);
  EXPECT_EQ(c->status, CameraStatus::kRegistered) << c->reason;
  const double error_ms = static_cast<double>(c->clock_offset->offset_ns - true_offset) * 1e-6;
  std::cout << "cam03 clock error " << error_ms << " ms (sigma " << c->clock_offset->sigma_ms
            << " ms)\n";
  EXPECT_LT(std::abs(error_ms), std::max(10.0, 4 * c->clock_offset->sigma_ms));
  const auto a = testing::accuracyAgainst(run.registration, truth, world_from_vo);
  EXPECT_EQ(a.compared, 6);
  EXPECT_LT(a.position_rmse_m, 0.01);
}

// revisit: a level L-shaped aisle driven out and back, cameras passed in
// straight lines. On a level floor the motion calibration's rotation about
// the vertical ties with its half turn (the scale's sign flipped); the
// stage once failed here with "non-positive scale".
TEST_F(PipelineTest, RevisitVisualLevelAisle) {
  expectSynthesisedOdometryRegisters("revisit", 8, 0.03, 0.5);
}

// The steps before the registration, one at a time (as the desktop app runs
// them): on a detections-only dataset detection is not needed, odometry is
// not needed in metric mode and cannot run in visual mode.
TEST_F(PipelineTest, StepsBeforeRegistrationSayWhyTheyAreSkipped) {
  FullPipelineOptions options;
  options.dataset = dataset("small");
  options.mode = TrajectoryMode::kMetric;
  options.trajectory_label = "odometry";
  const DatasetContents contents = inspectDataset(options.dataset, ProgressReporter());
  const std::vector<ConfigLayer> layers = configurationLayers(std::nullopt);
  EXPECT_EQ(contents.fisheye_frames, 0);
  EXPECT_GT(contents.markers, 0);
  const StepOutcome detect = runDetectStep(options, layers, contents, ProgressReporter());
  EXPECT_FALSE(detect.ran);
  EXPECT_EQ(detect.summary, "detect: skipped (no frames: detections-only dataset)");
  const StepOutcome odometry = runOdometryStep(options, layers, contents, ProgressReporter());
  EXPECT_FALSE(odometry.ran);
  EXPECT_EQ(odometry.summary, "odometry: skipped (metric trajectory)");
  options.mode = TrajectoryMode::kVisual;
  options.trajectory_label.clear();
  try {
    runOdometryStep(options, layers, contents, ProgressReporter());
    ADD_FAILURE() << "visual odometry without fisheye frames did not fail";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no fisheye frames"), std::string::npos) << e.what();
  }
}

// RegistrationPipeline one step at a time (as the desktop app runs it):
// detect, odometry, each configured stage, output; the same cameras as
// run(), and settings handed over in memory (over default.yaml) take effect.
TEST_F(PipelineTest, ThePipelineRunsOneStepAtATimeLikeRun) {
  FullPipelineOptions options;
  options.dataset = dataset("small");
  options.mode = TrajectoryMode::kMetric;
  options.trajectory_label = "odometry";
  options.out = *dir_ / "stepped_registration";
  options.overwrite = true;
  options.config_overrides = "register:\n  pipeline: [associate, motion_calibration, look_down]\n";
  RegistrationPipeline stepped(options);
  EXPECT_EQ(stepped.steps(),
            (std::vector<std::string>{"detect", "odometry", "associate", "motion_calibration",
                                      "look_down", "output"}));
  EXPECT_EQ(stepped.session(), nullptr);
  std::vector<std::string> lines;
  while (!stepped.finished()) {
    const std::string name = stepped.steps()[stepped.stepsRun()];
    const StepOutcome outcome = stepped.runNext(ProgressReporter());
    lines.push_back(name + ": " + (outcome.ran ? "ran" : "skipped"));
    if (name == "associate") {
      ASSERT_NE(stepped.session(), nullptr);
      EXPECT_EQ(stepped.session()->stagesRun(), 1u);
    }
  }
  EXPECT_EQ(lines,
            (std::vector<std::string>{"detect: skipped", "odometry: skipped", "associate: ran",
                                      "motion_calibration: ran", "look_down: ran", "output: ran"}));
  EXPECT_THROW(stepped.runNext(ProgressReporter()), Error);
  const Registration written = loadRegistration(options.out);
  EXPECT_EQ(written.pipeline,
            (std::vector<std::string>{"associate", "motion_calibration", "look_down"}));

  options.out = *dir_ / "run_registration";
  const FullPipelineResult all = runFullPipeline(options, ProgressReporter());
  ASSERT_EQ(all.run.registration.cameras.size(), written.cameras.size());
  for (std::size_t i = 0; i < written.cameras.size(); ++i) {
    EXPECT_LT((all.run.registration.cameras[i].world_from_camera.translation -
               written.cameras[i].world_from_camera.translation)
                  .norm(),
              1e-9)
        << written.cameras[i].label;
  }
  // A mistyped in-memory setting is an error that names it before any work.
  options.config_overrides = "register:\n  look_down: {huberr: 0.1}\n";
  try {
    RegistrationPipeline bad(options);
    ADD_FAILURE() << "an unknown key in the settings did not fail";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(kInMemorySettings), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("huberr"), std::string::npos) << e.what();
  }
}

// `faults` with seed 6: false detections (markers lying on the floor) and a
// camera whose clock jumps by 250 ms make motion pairs that no rigid motion
// explains. Before they were set aside, the motion calibration's linear
// start put the mount 54 deg off even with the true trajectory: the paper's
// stages ended 2.3 m off, and joint, from their start, 80 mm.
TEST_F(PipelineTest, Faults6FalseDetectionsDoNotDerailTheMount) {
  for (const bool paper : {true, false}) {
    SCOPED_TRACE(paper ? "paper.yaml" : "default");
    RegistrationInput input;
    const RegistrationRun run = registerDataset("faults6", TrajectoryMode::kMetric, "odometry",
                                                &input, paperConfigOr(paper));
    const Registration& r = run.registration;
    EXPECT_NE(r.observability.message.find("set aside"), std::string::npos)
        << r.observability.message;
    const auto a = testing::accuracyAgainst(r, input.manifest.ground_truth.world_from_camera);
    std::cout << (paper ? "paper" : "default") << ": " << a.compared << " cameras, "
              << a.position_rmse_m * 1e3 << " mm, " << a.rotation_rmse_deg << " deg\n";
    EXPECT_GE(a.compared, 5);
    EXPECT_LT(a.position_rmse_m, paper ? 0.05 : 0.015) << a.compared << " cameras compared";
    EXPECT_LT(a.rotation_rmse_deg, paper ? 5.0 : 0.5);
  }
}

// The faults scenario under the paper's stages (share/lookboth/config/paper.yaml)
// and under the default pipeline, which ends with the joint adjustment.
TEST_F(PipelineTest, FaultsCompleteWithFaultsReported) {
  for (const bool paper : {true, false}) {
    SCOPED_TRACE(paper ? "paper.yaml" : "default");
    RegistrationInput input;
    const RegistrationRun run = registerDataset("faults", TrajectoryMode::kMetric, "odometry",
                                                &input, paperConfigOr(paper));
    const Registration& r = run.registration;
    ASSERT_EQ(r.cameras.size(), 7u);
    // The unvisited camera: unregistered, with the reason.
    const CameraRegistration* unvisited = r.findCamera("cam06");
    ASSERT_NE(unvisited, nullptr);
    EXPECT_EQ(unvisited->status, CameraStatus::kUnregistered);
    EXPECT_NE(unvisited->reason.find("never detected"), std::string::npos);
    // The camera whose clock is 250 ms off: its detections disagree for the
    // paper's stages; the joint adjustment estimates the offset and registers it.
    const CameraRegistration* jumped = r.findCamera("cam00");
    ASSERT_NE(jumped, nullptr);
    if (paper) {
      // Suspect, or unregistered when too few of its detections agree on one
      // pose (on some noise realisations 2 of its 73 do): which of the two
      // depends on the noise; the disagreement is said either way.
      EXPECT_NE(jumped->status, CameraStatus::kRegistered) << jumped->reason;
      EXPECT_NE(jumped->reason.find("disagree"), std::string::npos) << jumped->reason;
      EXPECT_GT(jumped->detections.rejected, 0);
    } else {
      EXPECT_EQ(jumped->status, CameraStatus::kRegistered) << jumped->reason;
      ASSERT_TRUE(jumped->clock_offset.has_value());
      EXPECT_NEAR(static_cast<double>(jumped->clock_offset->offset_ns) * 1e-6, 250.0, 20.0);
      bool noted = false;
      for (const std::string& n : jumped->notes) {
        noted = noted || n.find("registered although look_down was not") != std::string::npos;
      }
      EXPECT_TRUE(noted) << "no note that look_down could not register cam00";
      // Its clock is the one thing to act on: the only camera with a warning.
      for (const CameraRegistration& c : r.cameras) {
        if (c.label == "cam00") {
          ASSERT_EQ(c.warnings.size(), 1u) << ::testing::PrintToString(c.warnings);
          EXPECT_NE(c.warnings[0].find("clock offset"), std::string::npos) << c.warnings[0];
        } else {
          EXPECT_TRUE(c.warnings.empty()) << c.label << ": " << c.warnings.front();
        }
      }
    }
    // The others are registered and near the truth.
    const auto a = testing::accuracyAgainst(r, input.manifest.ground_truth.world_from_camera);
    EXPECT_EQ(a.compared, jumped->status == CameraStatus::kUnregistered ? 5 : 6);
    EXPECT_LT(a.position_rmse_m, paper ? 0.1 : 0.03);
    EXPECT_FALSE(r.notes.empty());
  }
}

TEST_F(PipelineTest, VisualWithoutVoSaysToRunOdometry) {
  RegisterOptions options;
  options.dataset = dataset("small");
  options.mode = TrajectoryMode::kVisual;
  try {
    loadRegistrationInput(options, ProgressReporter());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lookboth odometry"), std::string::npos) << e.what();
  }
}

// The trajectory register uses when the user names none: the dataset's
// visual odometry, its only unscaled trajectory, odometry on its fisheye
// frames, its metric one; never the ground truth; errors list what is there.
TEST(ChooseTrajectory, FollowsTheDatasetsOwnDescription) {
  const auto contents = [](std::vector<TrajectoryInfo> trajectories, std::int64_t fisheye) {
    DatasetContents c;
    c.trajectories = std::move(trajectories);
    c.fisheye_frames = fisheye;
    return c;
  };
  const TrajectoryInfo vo{"vo", false, ""}, slam{"slam", false, ""}, wheels{"odometry", true, ""},
      lidar{"lidar", true, ""}, truth{"ground_truth", true, ""};
  const auto choose = [](const DatasetContents& c) { return chooseTrajectory("ds", c); };
  EXPECT_EQ(choose(contents({wheels, vo, truth}, 10)).label, "vo");
  const TrajectoryChoice own = choose(contents({wheels, slam, truth}, 10));
  EXPECT_EQ(own.label, "slam");
  EXPECT_EQ(own.mode, TrajectoryMode::kVisual);
  EXPECT_EQ(choose(contents({wheels, truth}, 10)).label, "vo");  // odometry will make it
  const TrajectoryChoice metric = choose(contents({truth, wheels}, 0));
  EXPECT_EQ(metric.label, "odometry");
  EXPECT_EQ(metric.mode, TrajectoryMode::kMetric);
  EXPECT_EQ(choose(contents({truth, lidar}, 0)).label, "lidar");
  const auto message = [&](const DatasetContents& c) {
    try {
      choose(c);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(choose(contents({slam, vo}, 0)).label, "vo");  // its own visual odometry first
  const std::string several = message(contents({slam, {"slam2", false, ""}}, 0));
  EXPECT_NE(several.find("several trajectories up to scale"), std::string::npos) << several;
  EXPECT_NE(several.find("slam2 (up to scale)"), std::string::npos) << several;
  EXPECT_NE(message(contents({truth}, 0)).find("--trajectory-file"), std::string::npos);
  EXPECT_NE(message(contents({lidar, {"wheels", true, ""}}, 0)).find("--trajectory metric"),
            std::string::npos);
}

TEST_F(PipelineTest, WritesTheOutputDirectoryAtomically) {
  const RegistrationRun run = registerDataset("small", TrajectoryMode::kMetric, "odometry");
  const fs::path out = *dir_ / "out";
  writeRegistrationOutput(run, out, false);
  for (const char* file : {"cameras.csv", "registration.yaml", "trajectory.tum", "scene.3Dscene",
                           "blob_associations.csv"}) {
    EXPECT_TRUE(fs::exists(out / file)) << file;
  }
  // The scene reads back in MRPT: trajectory, rays and one object per camera.
  mrpt::opengl::COpenGLScene scene;
  ASSERT_TRUE(scene.loadFromFile((out / "scene.3Dscene").string()));
  EXPECT_TRUE(scene.getByName("trajectory"));
  EXPECT_TRUE(scene.getByName("detection rays"));
  EXPECT_TRUE(scene.getByName("cam03"));
  const Registration back = loadRegistration(out);
  EXPECT_EQ(back.cameras.size(), run.registration.cameras.size());
  EXPECT_EQ(back.blob_associations.size(), run.registration.blob_associations.size());
  EXPECT_EQ(back.trajectory.size(), run.registration.trajectory.size());
  EXPECT_THROW(writeRegistrationOutput(run, out, false), Error);
  writeRegistrationOutput(run, out, true);
  // No temporary left beside it.
  for (const auto& entry : fs::directory_iterator(*dir_)) {
    EXPECT_EQ(entry.path().filename().string().find(".out."), std::string::npos);
  }
  const std::string summary = registrationSummary(run.registration);
  EXPECT_NE(summary.find("registered 6 of 6 cameras"), std::string::npos) << summary;
  // The default pipeline ends with joint, which predicts the aligned error.
  ASSERT_TRUE(run.registration.observability.aligned_position_rmse_m);
  EXPECT_NE(summary.find("predicted after a rigid alignment"), std::string::npos) << summary;
  ASSERT_TRUE(back.observability.aligned_position_rmse_m);
  EXPECT_NEAR(*back.observability.aligned_position_rmse_m,
              *run.registration.observability.aligned_position_rmse_m, 1e-12);
}

/// `small`'s first `seconds` rendered into a fresh `dir` (small.rawlog).
sim::SimulateOptions renderSmall(const fs::path& dir, double seconds) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  sim::SimulateOptions simulate;
  simulate.scenario = "small";
  simulate.out = dir / "small.rawlog";
  simulate.max_duration_s = seconds;
  simulate.threads = 2;
  sim::simulate(simulate, ProgressReporter());
  return simulate;
}

/// A rawlog whose fisheye frames are not all in time order: the blob search
/// beside the odometry (which sees them in the file's order) gives way to
/// detection's own, which sorts them: the same blobs as one step after the
/// other.
TEST(OverlappedSteps, FisheyeFramesOutOfOrderGiveTheSameBlobs) {
  const fs::path dir =
      fs::temp_directory_path() / ("lookboth_overlapped_order_" + std::to_string(::getpid()));
  const sim::SimulateOptions simulate = renderSmall(dir, 8.0);
  // Fisheye frames 30 and 31 swapped in the file.
  const fs::path shuffled = dir / "shuffled.rawlog";
  {
    auto reader = DatasetReader::open(simulate.out);
    auto writer = DatasetWriter::create(shuffled, DatasetKind::kRawlog, reader->manifest());
    std::optional<Record> held;
    int fisheye_frames = 0;
    while (std::optional<Record> record = reader->next()) {
      const auto* frame = std::get_if<ImageFrame>(&*record);
      const bool fisheye = frame && frame->sensor == reader->manifest().fisheye()->label;
      if (fisheye && ++fisheye_frames == 30) {
        held = std::move(*record);
        continue;
      }
      writer->write(*record);
      if (fisheye && held) writer->write(*std::exchange(held, std::nullopt));
    }
    writer->finish();
  }
  // Detection and the odometry only: what the blobs are.
  auto detectLine = [&](bool overlap) {
    FullPipelineOptions options;
    options.dataset = shuffled;
    options.choose_trajectory = true;
    options.write_back = false;
    options.overlap_steps = overlap;
    options.out = dir / "registration";
    RegistrationPipeline pipeline(options);
    const std::string detect = pipeline.runNext(ProgressReporter()).summary;
    const std::string odometry = pipeline.runNext(ProgressReporter()).summary;
    EXPECT_EQ(odometry.find("alongside detection") != std::string::npos, overlap) << odometry;
    // Not in the odometry's frames: they are not in time order.
    EXPECT_EQ(odometry.find("blobs searched in its frames"), std::string::npos) << odometry;
    return detect;
  };
  const std::string overlapped = detectLine(true);
  EXPECT_NE(overlapped.find(" fisheye frames with blobs"), std::string::npos) << overlapped;
  EXPECT_EQ(overlapped, detectLine(false));
  fs::remove_all(dir);
}

/// A rendered recording's first 12 s registered with detection and odometry
/// at once (overlap_steps) and one after the other: the same registration;
/// a stop during the overlapped detection stops the odometry too and leaves
/// the dataset and the output as they were; a failed odometry leaves the
/// detections written.
TEST(OverlappedSteps, SameRegistrationAsOneStepAfterTheOtherAndAStopStopsBoth) {
  const fs::path dir =
      fs::temp_directory_path() / ("lookboth_overlapped_steps_" + std::to_string(::getpid()));
  const sim::SimulateOptions simulate = renderSmall(dir, 12.0);
  const auto before = fs::last_write_time(simulate.out);

  FullPipelineOptions options;
  options.dataset = simulate.out;
  options.choose_trajectory = true;
  options.write_back = false;
  options.out = dir / "overlapped";
  const FullPipelineResult overlapped = runFullPipeline(options, ProgressReporter());
  options.overlap_steps = false;
  options.out = dir / "sequential";
  const FullPipelineResult sequential = runFullPipeline(options, ProgressReporter());
  auto line = [](const FullPipelineResult& result, const std::string& step) {
    for (const std::string& l : result.steps) {
      if (l.rfind(step + ": ", 0) == 0) return l;
    }
    return std::string();
  };
  EXPECT_NE(line(overlapped, "odometry").find("alongside detection"), std::string::npos)
      << line(overlapped, "odometry");
  EXPECT_NE(line(overlapped, "odometry").find("blobs searched in its frames"), std::string::npos)
      << line(overlapped, "odometry");
  EXPECT_EQ(line(sequential, "odometry").find("alongside"), std::string::npos)
      << line(sequential, "odometry");
  // The blobs searched in the odometry's frames are detection's own.
  EXPECT_EQ(line(overlapped, "detect"), line(sequential, "detect"));
  EXPECT_EQ(overlapped.run.registration.blob_associations.size(),
            sequential.run.registration.blob_associations.size());
  const auto& a = overlapped.run.registration.cameras;
  const auto& b = sequential.run.registration.cameras;
  ASSERT_EQ(a.size(), b.size());
  EXPECT_GE(overlapped.run.registration.registeredCount(), 2u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].status, b[i].status) << a[i].label;
    EXPECT_LT((a[i].world_from_camera.translation - b[i].world_from_camera.translation).norm(),
              1e-9)
        << a[i].label;
  }

  // Stopped while detection runs (and the odometry beside it).
  options.overlap_steps = true;
  options.out = dir / "stopped";
  ProgressReporter progress;
  progress = progress.withCallback([progress](const ProgressEvent& event) {
    if (event.stage == "detect" && event.done > 50) progress.requestStop();
  });
  EXPECT_THROW(runFullPipeline(options, progress), StopRequested);
  EXPECT_FALSE(fs::exists(options.out));
  EXPECT_EQ(fs::last_write_time(simulate.out), before);
  std::size_t entries = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    ++entries;
    EXPECT_EQ(entry.path().filename().string().find("-dataset-tmp-"), std::string::npos)
        << entry.path();
  }
  EXPECT_EQ(entries, 5u);  // small.rawlog, its manifest and images, and the two registrations

  // The odometry fails (it cannot initialise): the detections it ran beside
  // are written all the same, and the odometry's step says why.
  options.write_back = true;
  options.out = dir / "failed";
  options.config_overrides = "odometry:\n  init_min_parallax_deg: 80\n";
  try {
    runFullPipeline(options, ProgressReporter());
    ADD_FAILURE() << "an odometry that cannot initialise did not fail";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("odometry"), std::string::npos) << e.what();
  }
  const DatasetContents after = inspectDataset(simulate.out, ProgressReporter());
  EXPECT_GT(after.markers, 0);
  EXPECT_GT(after.blob_records, 0);
  EXPECT_FALSE(after.hasTrajectory("vo"));
  fs::remove_all(dir);
}

TEST(RegistrationConfig, UserFileOverridesAndErrorsNameTheField) {
  const std::string defaults =
      "register:\n  pipeline: [associate, look_down]\n  look_down: {min_detections: 3}\n";
  RegistrationConfig config = registrationConfigFromYaml(
      {{defaults, "default.yaml"}, {"register:\n  look_down: {min_detections: 7}\n", "user.yaml"}});
  EXPECT_EQ(config.pipeline, (std::vector<std::string>{"associate", "look_down"}));
  EXPECT_NE(config.mergedYaml().find("min_detections: 7"), std::string::npos);
  EXPECT_NO_THROW(RegistrationController{config});
  try {
    registrationConfigFromYaml(
        {{defaults, "default.yaml"}, {"register:\n  look_down: {min_detectionz: 7}\n", "u.yaml"}});
    RegistrationController{registrationConfigFromYaml(
        {{defaults, "default.yaml"}, {"register:\n  look_down: {min_detectionz: 7}\n", "u.yaml"}})};
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("u.yaml:2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("min_detectionz"), std::string::npos) << e.what();
  }
  try {
    RegistrationController{registrationConfigFromYaml(
        {{defaults, "default.yaml"}, {"register:\n  look_down: {min_detections: 0}\n", "u.yaml"}})};
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("register.look_down"), std::string::npos) << e.what();
  }
  EXPECT_THROW(registrationConfigFromYaml({{"register:\n  pipeline: [joint_magic]\n", "x.yaml"}}),
               Error);
}

// The desktop app's settings, as it hands them over (each typed value a
// quoted scalar): the stages' own options read and check them, and the
// message names the setting the window marks.
TEST(RegistrationConfig, InMemorySettingsAreReadAndCheckedByTheStages) {
  auto problem = [](const std::string& huber, const std::string& gate) {
    const std::string text = "register:\n  look_down: {huber: \"" + huber +
                             "\"}\n  look_up: {cauchy_px: \"2.0\", gate_px: \"" + gate + "\"}\n";
    try {
      const RegistrationController controller(loadRegistrationConfig(std::nullopt, text));
      EXPECT_DOUBLE_EQ(
          readStageOptions<LookDownOptions>(controller.config().stageConfig("look_down")).huber,
          std::stod(huber));
      return std::string();
    } catch (const Error& e) {
      return std::string(e.what());
    }
  };
  EXPECT_EQ(problem("3.0", "25"), "");
  const std::string negative = problem("-1", "25");
  EXPECT_NE(negative.find("'huber': must be positive"), std::string::npos) << negative;
  const std::string typo = problem("3,0", "25");
  EXPECT_NE(typo.find("register.look_down.huber"), std::string::npos) << typo;
  EXPECT_NE(typo.find("is not a finite number"), std::string::npos) << typo;
  EXPECT_NE(typo.find(kInMemorySettings), std::string::npos) << typo;
  const std::string narrow = problem("3.0", "2");  // below min_gate_px (5)
  EXPECT_NE(narrow.find("gate_px"), std::string::npos) << narrow;
}

TEST(RegistrationConfig, ShippedDefaultsAreValid) {
  const RegistrationConfig config = loadRegistrationConfig(std::nullopt);
  EXPECT_EQ(config.pipeline, (std::vector<std::string>{"associate", "motion_calibration",
                                                       "look_down", "look_up", "joint"}));
  EXPECT_NO_THROW(RegistrationController{config});
}

TEST(StageRegistry, NewStagesRegisterBesideThePapers) {
  // A stage added by name runs in the pipeline without any change to the controller.
  struct FixedMount : RegistrationStage {
    std::string name() const override { return "fixed_mount"; }
    void run(RegistrationProblem& problem, const ProgressReporter&) override {
      problem.fisheye_from_marker = problem.input.manifest.ground_truth.fisheye_from_marker;
      problem.scale = 1;
    }
  };
  StageRegistry registry;
  registerPaperStages(registry);
  registry.add("fixed_mount", "test", [](const StageConfig&) {
    return std::unique_ptr<RegistrationStage>(new FixedMount);
  });
  RegistrationConfig config = loadRegistrationConfig(std::nullopt);
  config.pipeline = {"associate", "fixed_mount", "look_down"};
  const testing::SyntheticScene scene = testing::makeSyntheticScene({});
  const RegistrationController controller(config, registry);
  const RegistrationRun run = controller.run(scene.input, ProgressReporter());
  const auto a = testing::accuracyAgainst(run.registration, scene.world_from_camera);
  EXPECT_EQ(a.compared, 6);
  EXPECT_LT(a.position_max_m, 1e-6);
  EXPECT_EQ(run.registration.pipeline,
            (std::vector<std::string>{"associate", "fixed_mount", "look_down"}));
}

// The desktop app runs the stages one at a time on a kept problem: the result
// after the last stage is the one run() gives, and each stage adds its part.
TEST(Controller, RunsOneStageAtATimeLikeRun) {
  const testing::SyntheticScene scene = testing::makeSyntheticScene({});
  const RegistrationController controller(loadRegistrationConfig(std::nullopt));
  const RegistrationRun whole = controller.run(scene.input, ProgressReporter());

  RegistrationSession session = controller.prepare(scene.input);
  ASSERT_EQ(session.stageCount(), controller.config().pipeline.size());
  EXPECT_EQ(session.stagesRun(), 0u);
  EXPECT_TRUE(session.current().registration.pipeline.empty());
  bool registered_before_end = false;
  for (std::size_t i = 0; i < session.stageCount(); ++i) {
    EXPECT_FALSE(session.finished());
    EXPECT_EQ(session.stageName(i), controller.config().pipeline[i]);
    session.runNext(ProgressReporter());
    EXPECT_EQ(session.stagesRun(), i + 1);
    const RegistrationRun now = session.current();
    ASSERT_EQ(now.registration.pipeline.size(), i + 1);
    EXPECT_EQ(now.registration.pipeline.back(), controller.config().pipeline[i]);
    if (controller.config().pipeline[i] == "associate") {
      EXPECT_TRUE(session.problem().associated);
      EXPECT_EQ(now.registration.registeredCount(), 0);
    }
    if (controller.config().pipeline[i] == "look_down") {
      EXPECT_EQ(now.registration.registeredCount(), 6);
      EXPECT_FALSE(now.rays.empty());
      registered_before_end = i + 1 < session.stageCount();
    }
  }
  EXPECT_TRUE(session.finished());
  EXPECT_TRUE(registered_before_end) << "look_down should come before the last stage";
  EXPECT_THROW(session.runNext(ProgressReporter()), Error);

  const RegistrationRun last = session.current();
  EXPECT_EQ(last.registration.pipeline, whole.registration.pipeline);
  EXPECT_EQ(last.registration.scale, whole.registration.scale);
  EXPECT_EQ(last.rays.size(), whole.rays.size());
  ASSERT_EQ(last.registration.cameras.size(), whole.registration.cameras.size());
  for (std::size_t i = 0; i < last.registration.cameras.size(); ++i) {
    const CameraRegistration& a = last.registration.cameras[i];
    const CameraRegistration& b = whole.registration.cameras[i];
    EXPECT_EQ(a.label, b.label);
    EXPECT_EQ(a.status, b.status);
    EXPECT_LT((a.world_from_camera.translation - b.world_from_camera.translation).norm(), 1e-9);
  }
  // Noise-free input: the stage-by-stage result is the truth.
  const auto accuracy = testing::accuracyAgainst(last.registration, scene.world_from_camera);
  EXPECT_EQ(accuracy.compared, 6);
  EXPECT_LT(accuracy.position_max_m, 1e-6);
}

TEST(Controller, StopBetweenStagesKeepsTheStagesRun) {
  const testing::SyntheticScene scene = testing::makeSyntheticScene({});
  const RegistrationController controller(loadRegistrationConfig(std::nullopt));
  RegistrationSession session = controller.prepare(scene.input);
  session.runNext(ProgressReporter());
  ProgressReporter stopped;
  stopped.requestStop();
  EXPECT_THROW(session.runNext(stopped), StopRequested);
  EXPECT_EQ(session.stagesRun(), 1u);
  session.runNext(ProgressReporter());
  EXPECT_EQ(session.stagesRun(), 2u);
}

TEST(Controller, StopsWhenAsked) {
  const testing::SyntheticScene scene = testing::makeSyntheticScene({});
  const RegistrationController controller(loadRegistrationConfig(std::nullopt));
  ProgressReporter progress;
  progress.requestStop();
  EXPECT_THROW(controller.run(scene.input, progress), StopRequested);
}

}  // namespace
}  // namespace lookboth
