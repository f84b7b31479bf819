#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/core/paths.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/sim/simulate.h"
#include "lookboth/studio/dataset_edit.h"
#include "lookboth/studio/dataset_index.h"
#include "lookboth/studio/job_runner.h"

namespace lookboth::studio {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("lookboth_studio_test_" +
             std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

TEST(DatasetIndexTest, IndexesASimulatedDatasetByCameraAndTime) {
  TempDir dir;
  sim::SimulateOptions options;
  options.scenario = "small";
  options.out = dir.path() / "small.rawlog";
  options.detections_only = true;
  options.max_duration_s = 20;
  const sim::SimulateSummary summary = sim::simulate(options, ProgressReporter());

  std::int64_t last_done = -1;
  const DatasetIndex index = DatasetIndex::build(
      options.out, ProgressReporter([&](const ProgressEvent& e) { last_done = e.done; }));
  EXPECT_EQ(last_done, summary.total());
  EXPECT_EQ(index.recordCounts().at("marker"), summary.records.at("marker"));
  EXPECT_EQ(static_cast<std::int64_t>(index.blobs().size()), summary.records.at("blobs"));
  ASSERT_NE(index.trajectory("ground_truth"), nullptr);
  ASSERT_NE(index.trajectory("odometry"), nullptr);
  EXPECT_TRUE(index.fisheyeFrames().empty());  // detections only: no images

  const auto rows = index.cameraSummaries();
  EXPECT_EQ(static_cast<int>(rows.size()), summary.cameras);
  std::int64_t detections = 0;
  for (const auto& row : rows) {
    EXPECT_TRUE(row.has_calibration) << row.label;
    detections += row.detections;
    const auto& markers = index.markers(row.label);
    for (size_t i = 1; i < markers.size(); ++i) EXPECT_LE(markers[i - 1].t, markers[i].t);
    if (row.detections > 0) {
      EXPECT_LE(row.first_detection, row.last_detection);
    }
  }
  EXPECT_EQ(detections, summary.records.at("marker"));
  ASSERT_FALSE(index.blobs().empty());
  const BlobObservation& some = index.blobs()[index.blobs().size() / 2];
  ASSERT_NE(index.blobsAt(some.t), nullptr);
  EXPECT_EQ(index.blobsAt(some.t)->t, some.t);
  EXPECT_EQ(index.blobsAt(some.t + 1), nullptr);
  EXPECT_TRUE(index.markers("no such camera").empty());
}

// Markers fixed on the floor are kept apart: the camera table and the views
// count and draw the robot's marker alone.
TEST(DatasetIndexTest, KeepsFixedMarkersApartFromTheRobots) {
  TempDir dir;
  std::ifstream in(shareDirectory() / "scenarios" / "small.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::ofstream(dir.path() / "floor.yaml")
      << text.str() << "\nfloor_markers:\n  - {id: 23, position_m: [2.9, 2.4, 0]}\n";
  sim::SimulateOptions options;
  options.scenario = (dir.path() / "floor.yaml").string();
  options.out = dir.path() / "drive.rawlog";
  options.detections_only = true;
  options.max_duration_s = 10;
  sim::simulate(options, ProgressReporter());
  const DatasetIndex index = DatasetIndex::build(options.out);
  ASSERT_FALSE(index.fixedMarkers().empty());
  for (const MarkerObservation& m : index.fixedMarkers()) EXPECT_EQ(m.marker_id, 23);
  std::int64_t robot = 0;
  for (const auto& row : index.cameraSummaries()) {
    for (const MarkerObservation& m : index.markers(row.label)) {
      EXPECT_EQ(m.marker_id, index.manifest().marker.id);
    }
    robot += row.detections;
  }
  EXPECT_EQ(robot + static_cast<std::int64_t>(index.fixedMarkers().size()),
            index.recordCounts().at("marker"));
}

TEST(DatasetIndexTest, MissingDatasetIsAnErrorNamingIt) {
  try {
    DatasetIndex::build("/nonexistent/lookboth/x.rawlog");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("x.rawlog"), std::string::npos) << e.what();
  }
}

// Waits for a JobRunner's completion callback.
struct DoneLatch {
  std::mutex mutex;
  std::condition_variable cv;
  bool done = false;
  JobResult result;
  void set(const JobResult& r) {
    std::lock_guard<std::mutex> lock(mutex);
    result = r;
    done = true;
    cv.notify_all();
  }
  JobResult get() {
    std::unique_lock<std::mutex> lock(mutex);
    cv.wait(lock, [&] { return done; });
    return result;
  }
};

TEST(JobRunnerTest, ReportsSuccessProgressAndErrors) {
  JobRunner runner;
  DoneLatch ok;
  std::int64_t progress_seen = 0;
  ASSERT_TRUE(runner.start(
      "count", [](const ProgressReporter& p) { p.report("count", 3, 3); },
      [&](const ProgressEvent& e) { progress_seen = e.done; },
      [&](const JobResult& r) { ok.set(r); }));
  EXPECT_EQ(ok.get().status, JobStatus::kSucceeded);
  runner.wait();
  EXPECT_EQ(progress_seen, 3);

  DoneLatch failed;
  ASSERT_TRUE(runner.start(
      "bad", [](const ProgressReporter&) { throw Error("x.yaml: bad field"); }, nullptr,
      [&](const JobResult& r) { failed.set(r); }));
  const JobResult r = failed.get();
  EXPECT_EQ(r.status, JobStatus::kFailed);
  EXPECT_NE(r.message.find("x.yaml"), std::string::npos);
}

TEST(JobRunnerTest, StopRequestEndsALongJobAsStoppedAndRefusesASecondJob) {
  JobRunner runner;
  DoneLatch done;
  std::atomic<bool> started{false};
  ASSERT_TRUE(runner.start(
      "long",
      [&](const ProgressReporter& p) {
        started = true;
        for (;;) {
          p.checkStop();
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
      },
      nullptr, [&](const JobResult& r) { done.set(r); }));
  while (!started) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  EXPECT_TRUE(runner.running());
  EXPECT_FALSE(runner.start(
      "second", [](const ProgressReporter&) {}, nullptr, nullptr));
  runner.requestStop();
  EXPECT_EQ(done.get().status, JobStatus::kStopped);
  runner.wait();
  EXPECT_FALSE(runner.running());
}

// File > Load camera calibration: the manifest gets the new model, the
// records stay; a bad file or an unknown camera changes nothing.
TEST(DatasetEditTest, SetsACameraCalibrationAndKeepsTheRecords) {
  TempDir dir;
  sim::SimulateOptions options;
  options.scenario = "small";
  options.out = dir.path() / "small.rawlog";
  options.detections_only = true;
  options.max_duration_s = 5;
  sim::simulate(options, ProgressReporter());
  const DatasetIndex before = DatasetIndex::build(options.out);
  const CameraSensor* fisheye = before.manifest().fisheye();
  ASSERT_TRUE(fisheye && fisheye->camera);
  const CameraSensor* cam00 = before.manifest().findCamera("cam00");
  ASSERT_TRUE(cam00 && cam00->camera);
  ASSERT_NE(cameraToYaml(*fisheye->camera), cameraToYaml(*cam00->camera));
  // cam00 gets the fisheye's model: different from its own, easy to recognise.
  const fs::path file = dir.path() / "calibration.yaml";
  saveCamera(*fisheye->camera, file);
  const Camera set = setCameraCalibration(options.out, "cam00", file, ProgressReporter());
  EXPECT_EQ(cameraToYaml(set), cameraToYaml(*fisheye->camera));

  const DatasetIndex after = DatasetIndex::build(options.out);
  const CameraSensor* changed = after.manifest().findCamera("cam00");
  ASSERT_TRUE(changed && changed->camera);
  EXPECT_EQ(cameraToYaml(*changed->camera), cameraToYaml(*fisheye->camera));
  EXPECT_EQ(cameraToYaml(*after.manifest().findCamera("cam01")->camera),
            cameraToYaml(*before.manifest().findCamera("cam01")->camera));
  EXPECT_EQ(after.recordCounts(), before.recordCounts());

  EXPECT_THROW(setCameraCalibration(options.out, "cam99", file, ProgressReporter()), Error);
  const fs::path bad = dir.path() / "bad.yaml";
  {
    std::ofstream out(bad);
    out << "not: a calibration\n";
  }
  try {
    setCameraCalibration(options.out, "cam01", bad, ProgressReporter());
    ADD_FAILURE() << "a file that is no calibration was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
  }
  EXPECT_EQ(cameraToYaml(*DatasetIndex::build(options.out).manifest().findCamera("cam01")->camera),
            cameraToYaml(*before.manifest().findCamera("cam01")->camera));
}

TEST(DatasetEditTest, SetsTheMarkerAndRefusesAnInvalidOne) {
  TempDir dir;
  sim::SimulateOptions options;
  options.scenario = "small";
  options.out = dir.path() / "small.rawlog";
  options.detections_only = true;
  options.max_duration_s = 5;
  sim::simulate(options, ProgressReporter());
  const DatasetIndex before = DatasetIndex::build(options.out);
  MarkerSpec marker;
  marker.dictionary = "DICT_5X5_100";
  marker.id = 42;
  marker.size_m = 0.15;
  ASSERT_NE(before.manifest().marker.id, 42);
  setMarker(options.out, marker, ProgressReporter());
  const DatasetIndex after = DatasetIndex::build(options.out);
  EXPECT_EQ(after.manifest().marker.dictionary, "DICT_5X5_100");
  EXPECT_EQ(after.manifest().marker.id, 42);
  EXPECT_DOUBLE_EQ(after.manifest().marker.size_m, 0.15);
  EXPECT_EQ(after.recordCounts(), before.recordCounts());
  MarkerSpec bad = marker;
  bad.size_m = -1;
  EXPECT_THROW(setMarker(options.out, bad, ProgressReporter()), Error);
  EXPECT_EQ(DatasetIndex::build(options.out).manifest().marker.id, 42);
}

}  // namespace
}  // namespace lookboth::studio
