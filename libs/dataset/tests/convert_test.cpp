#include "lookboth/dataset/convert.h"

#include <gtest/gtest.h>

#include "lookboth/core/error.h"
#include "lookboth/geometry/tum.h"
#include "test_dataset.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

class ConvertTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_convert_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path writeSampleRawlog() {
    const fs::path rawlog = dir_ / "sample.rawlog";
    auto writer = DatasetWriter::create(rawlog, DatasetKind::kRawlog, testing::sampleManifest());
    for (const Record& r : testing::withCorners(testing::sampleRecords())) writer->write(r);
    writer->finish();
    return rawlog;
  }

  static std::vector<Record> readAll(const fs::path& path) {
    auto reader = DatasetReader::open(path);
    std::vector<Record> records;
    while (auto r = reader->next()) records.push_back(*r);
    return records;
  }

  // Records sorted by (time, kind, label): the rawlog keeps file order, the
  // folder reader merges by time; content must match either way.
  static std::vector<Record> sorted(std::vector<Record> records) {
    std::stable_sort(records.begin(), records.end(), [](const Record& a, const Record& b) {
      if (recordTime(a) != recordTime(b)) return recordTime(a) < recordTime(b);
      if (a.index() != b.index()) return a.index() < b.index();
      return recordLabel(a) < recordLabel(b);
    });
    return records;
  }

  static void expectSameRecords(const std::vector<Record>& a, const std::vector<Record>& b) {
    const auto sa = sorted(a), sb = sorted(b);
    ASSERT_EQ(sa.size(), sb.size());
    for (size_t i = 0; i < sa.size(); ++i)
      EXPECT_TRUE(testing::sameRecord(sa[i], sb[i])) << "record " << i;
  }

  static void expectSameManifest(const Manifest& a, const Manifest& b) {
    EXPECT_EQ(a.marker.dictionary, b.marker.dictionary);
    EXPECT_EQ(a.marker.id, b.marker.id);
    EXPECT_EQ(a.marker.size_m, b.marker.size_m);
    ASSERT_EQ(a.cameras.size(), b.cameras.size());
    for (const CameraSensor& camera : a.cameras) {
      const CameraSensor* other = b.findCamera(camera.label);
      ASSERT_NE(other, nullptr) << camera.label;
      EXPECT_EQ(other->role, camera.role);
      ASSERT_EQ(other->camera.has_value(), camera.camera.has_value());
      if (camera.camera) {
        EXPECT_EQ(other->camera->params(), camera.camera->params()) << camera.label;
      }
    }
    ASSERT_EQ(a.trajectories.size(), b.trajectories.size());
    for (const TrajectoryInfo& t : a.trajectories) {
      ASSERT_NE(b.findTrajectory(t.label), nullptr) << t.label;
      EXPECT_EQ(b.findTrajectory(t.label)->metric, t.metric) << t.label;
    }
    EXPECT_EQ(a.ground_truth.world_from_camera.size(), b.ground_truth.world_from_camera.size());
    for (const auto& [label, pose] : a.ground_truth.world_from_camera) {
      EXPECT_LT((b.ground_truth.world_from_camera.at(label).translation - pose.translation).norm(),
                1e-12);
    }
    EXPECT_EQ(a.ground_truth.clock_offset, b.ground_truth.clock_offset);
    EXPECT_EQ(a.ground_truth.hidden_from_fisheye.size(), b.ground_truth.hidden_from_fisheye.size());
    for (const auto& [label, spans] : a.ground_truth.hidden_from_fisheye) {
      ASSERT_EQ(b.ground_truth.hidden_from_fisheye.at(label).size(), spans.size()) << label;
      for (size_t i = 0; i < spans.size(); ++i) {
        EXPECT_EQ(b.ground_truth.hidden_from_fisheye.at(label)[i].begin, spans[i].begin);
        EXPECT_EQ(b.ground_truth.hidden_from_fisheye.at(label)[i].end, spans[i].end);
      }
    }
    ASSERT_EQ(a.ground_truth.fisheye_from_marker.has_value(),
              b.ground_truth.fisheye_from_marker.has_value());
  }

  fs::path dir_;
};

TEST_F(ConvertTest, RawlogToFolderToRawlogLosesNothing) {
  const fs::path rawlog = writeSampleRawlog();
  ConvertOptions to_folder;
  to_folder.from = rawlog;
  to_folder.to = dir_ / "folder";
  const ConvertSummary s1 = convertData(to_folder, ProgressReporter());
  EXPECT_EQ(s1.total(), static_cast<std::int64_t>(testing::sampleRecords().size()));
  EXPECT_EQ(s1.records.at("image"), 10);

  ConvertOptions back;
  back.from = dir_ / "folder";
  back.to = dir_ / "again.rawlog";
  convertData(back, ProgressReporter());

  expectSameRecords(readAll(rawlog), readAll(dir_ / "again.rawlog"));
  int with_corners = 0;
  for (const Record& r : readAll(dir_ / "again.rawlog")) {
    const auto* m = std::get_if<MarkerObservation>(&r);
    with_corners += m && m->corners_px.size() == 4;
  }
  EXPECT_EQ(with_corners, 5);  // the markers' corners crossed both formats
  expectSameManifest(DatasetReader::open(rawlog)->manifest(),
                     DatasetReader::open(dir_ / "again.rawlog")->manifest());
  EXPECT_EQ(DatasetReader::open(dir_ / "again.rawlog")->manifest().name, "again");
}

TEST_F(ConvertTest, ShippedFolderSampleToRawlogAndBack) {
  const fs::path sample = fs::path(LOOKBOTH_TEST_DATA_DIR) / "datasets" / "folder_small";
  ConvertOptions to_rawlog;
  to_rawlog.from = sample;
  to_rawlog.to = dir_ / "small.rawlog";
  const ConvertSummary summary = convertData(to_rawlog, ProgressReporter());
  EXPECT_GT(summary.total(), 0);
  ConvertOptions to_folder;
  to_folder.from = dir_ / "small.rawlog";
  to_folder.to = dir_ / "small_folder";
  convertData(to_folder, ProgressReporter());
  expectSameRecords(readAll(sample), readAll(dir_ / "small_folder"));
  expectSameManifest(DatasetReader::open(sample)->manifest(),
                     DatasetReader::open(dir_ / "small_folder")->manifest());
}

TEST_F(ConvertTest, TrajectoriesInAndOutAsTum) {
  const fs::path rawlog = writeSampleRawlog();
  ConvertOptions out;
  out.from = rawlog;
  out.to = dir_ / "gt.tum";
  out.trajectory_label = "ground_truth";
  EXPECT_EQ(convertData(out, ProgressReporter()).records.at("pose"), 10);
  const Trajectory gt = readTumFile(dir_ / "gt.tum");
  ASSERT_EQ(gt.size(), 10u);
  EXPECT_EQ(gt.startTime(), secondsToNs(1700000000) + 300);  // exact nanoseconds

  // TUM -> dataset, scaled.
  ConvertOptions in;
  in.from = dir_ / "gt.tum";
  in.to = dir_ / "traj.rawlog";
  in.trajectory_label = "vo";
  in.trajectory_metric = false;
  convertData(in, ProgressReporter());
  auto reader = DatasetReader::open(dir_ / "traj.rawlog");
  ASSERT_NE(reader->manifest().findTrajectory("vo"), nullptr);
  EXPECT_FALSE(reader->manifest().findTrajectory("vo")->metric);

  // Adding a trajectory while converting; a clash of labels is refused.
  ConvertOptions add;
  add.from = rawlog;
  add.to = dir_ / "with_vo.rawlog";
  add.add_trajectories.push_back({dir_ / "gt.tum", {"vo", false, "test"}});
  convertData(add, ProgressReporter());
  EXPECT_EQ(readAll(dir_ / "with_vo.rawlog").size(), testing::sampleRecords().size() + 10);
  add.to = dir_ / "clash.rawlog";
  add.add_trajectories = {{dir_ / "gt.tum", {"odometry", true, ""}}};
  EXPECT_THROW(convertData(add, ProgressReporter()), Error);
  EXPECT_FALSE(fs::exists(dir_ / "clash.rawlog"));

  // No label: 'odometry' when present, else the only trajectory.
  ConvertOptions default_label;
  default_label.from = dir_ / "traj.rawlog";  // holds only 'vo'
  default_label.to = dir_ / "only.tum";
  EXPECT_EQ(convertData(default_label, ProgressReporter()).records.at("pose"), 10);
  default_label.from = rawlog;
  default_label.to = dir_ / "odometry.tum";
  convertData(default_label, ProgressReporter());
  EXPECT_EQ(readTumFile(dir_ / "odometry.tum").startTime(),
            secondsToNs(1700000000));  // odometry, not ground_truth
}

TEST_F(ConvertTest, RefusesToWriteOverInputsOrExistingOutputs) {
  const fs::path rawlog = writeSampleRawlog();
  ConvertOptions same;
  same.from = rawlog;
  same.to = rawlog;
  EXPECT_THROW(convertData(same, ProgressReporter()), Error);
  ConvertOptions existing;
  existing.from = rawlog;
  existing.to = dir_ / "copy.rawlog";
  convertData(existing, ProgressReporter());
  try {
    convertData(existing, ProgressReporter());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--overwrite"), std::string::npos) << e.what();
  }
  existing.overwrite = true;
  EXPECT_NO_THROW(convertData(existing, ProgressReporter()));
}

TEST_F(ConvertTest, StopLeavesNoOutput) {
  const fs::path rawlog = writeSampleRawlog();
  int events = 0;
  ProgressReporter progress([&](const ProgressEvent&) { ++events; });
  progress.requestStop();
  ConvertOptions options;
  options.from = rawlog;
  options.to = dir_ / "stopped";
  EXPECT_THROW(convertData(options, progress), StopRequested);
  EXPECT_FALSE(fs::exists(dir_ / "stopped"));
  size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++entries;
  EXPECT_EQ(entries, 3u);  // sample.rawlog, sample.yaml, sample_Images: no temporary left
}

}  // namespace
}  // namespace lookboth
