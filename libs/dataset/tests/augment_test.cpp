#include "lookboth/dataset/augment.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>

#include <fstream>
#include <sstream>

#include "lookboth/core/error.h"
#include "test_dataset.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

class AugmentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_augment_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path writeSample(const fs::path& path, DatasetKind kind) {
    auto writer = DatasetWriter::create(path, kind, testing::sampleManifest());
    for (const Record& r : testing::withCorners(testing::sampleRecords())) writer->write(r);
    writer->finish();
    return path;
  }

  static std::vector<Record> readAll(const fs::path& path) {
    auto reader = DatasetReader::open(path);
    std::vector<Record> records;
    while (auto r = reader->next()) records.push_back(*r);
    return records;
  }

  static std::string fileBytes(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream out;
    out << in.rdbuf();
    return out.str();
  }

  /// Every file under dir_ (relative path -> bytes).
  std::map<std::string, std::string> snapshot() const {
    std::map<std::string, std::string> files;
    for (const auto& entry : fs::recursive_directory_iterator(dir_)) {
      if (entry.is_regular_file())
        files[fs::relative(entry.path(), dir_).string()] = fileBytes(entry.path());
    }
    return files;
  }

  /// New marker detections of cam00: one between every two input markers.
  static std::vector<Record> newMarkers() {
    std::vector<Record> added;
    const TimeNs t0 = secondsToNs(1700000000);
    for (int i = 9; i >= 0; --i) {  // deliberately not in time order
      MarkerObservation m;
      m.t = t0 + i * millisecondsToNs(100) + 2500;
      m.camera = "cam00";
      m.marker_id = 7;
      m.camera_from_marker =
          Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5, 0.25, 3.0 + i));
      m.information = Eigen::Matrix<double, 6, 6>::Identity() * 42.0;
      added.push_back(m);
    }
    return added;
  }

  static bool isOldMarker(const Record& r) { return std::holds_alternative<MarkerObservation>(r); }

  fs::path dir_;
};

TEST_F(AugmentTest, InPlaceReplacesDetectionsAndKeepsEverythingElse) {
  for (const DatasetKind kind : {DatasetKind::kRawlog, DatasetKind::kFolder}) {
    SCOPED_TRACE(datasetKindName(kind));
    const fs::path path = writeSample(
        dir_ / (kind == DatasetKind::kRawlog ? "sample.rawlog" : "sample_folder"), kind);
    const std::vector<Record> before = readAll(path);
    AugmentOptions options;
    options.input = path;
    options.drop = isOldMarker;
    Manifest manifest = DatasetReader::open(path)->manifest();
    manifest.trajectories.push_back({"vo", false, "added by the test"});
    options.manifest = manifest;
    const AugmentSummary summary = augmentDataset(options, newMarkers(), ProgressReporter());
    EXPECT_EQ(summary.added, 10);
    EXPECT_EQ(summary.dropped, 10);
    EXPECT_EQ(summary.copied, static_cast<std::int64_t>(before.size()) - 10);

    const std::vector<Record> after = readAll(path);
    ASSERT_EQ(after.size(), before.size());
    // Everything but the markers is unchanged, in the same order.
    std::vector<Record> kept_before, kept_after, markers;
    for (const Record& r : before)
      if (!isOldMarker(r)) kept_before.push_back(r);
    for (const Record& r : after) (isOldMarker(r) ? markers : kept_after).push_back(r);
    ASSERT_EQ(kept_before.size(), kept_after.size());
    for (std::size_t i = 0; i < kept_before.size(); ++i)
      EXPECT_TRUE(testing::sameRecord(kept_before[i], kept_after[i])) << i;
    ASSERT_EQ(markers.size(), 10u);
    for (const Record& r : markers) {
      EXPECT_DOUBLE_EQ(std::get<MarkerObservation>(r).information(0, 0), 42.0);
    }
    // In time order.
    for (std::size_t i = 1; i < after.size(); ++i) {
      EXPECT_LE(recordTime(after[i - 1]), recordTime(after[i])) << i;
    }
    auto reader = DatasetReader::open(path);
    EXPECT_NE(reader->manifest().findTrajectory("vo"), nullptr);
    // No temporary or old copy left beside it.
    std::size_t entries = 0;
    for (const auto& e : fs::directory_iterator(dir_)) {
      EXPECT_NE(e.path().filename().string().front(), '.') << e.path();
      ++entries;
    }
    EXPECT_EQ(entries, kind == DatasetKind::kRawlog ? 3u : 4u);
  }
}

TEST_F(AugmentTest, SeparateOutputHardLinksImagesAndLeavesTheInputAlone) {
  const fs::path input = writeSample(dir_ / "in.rawlog", DatasetKind::kRawlog);
  const auto before = snapshot();
  AugmentOptions options;
  options.input = input;
  options.output = dir_ / "out.rawlog";
  augmentDataset(options, newMarkers(), ProgressReporter());
  std::map<std::string, std::string> after = snapshot();
  for (const auto& [name, bytes] : before) EXPECT_EQ(after.at(name), bytes) << name;
  EXPECT_EQ(readAll(dir_ / "out.rawlog").size(), readAll(input).size() + 10);
  EXPECT_EQ(DatasetReader::open(dir_ / "out.rawlog")->manifest().name, "out");
  // The images are the input's files (one inode, two names).
  int linked = 0;
  for (const auto& e : fs::directory_iterator(dir_ / "out_Images")) {
    const fs::path twin = dir_ / "in_Images" / e.path().filename();
    ASSERT_TRUE(fs::exists(twin));
    EXPECT_TRUE(fs::equivalent(twin, e.path()));
    EXPECT_EQ(fs::hard_link_count(twin), 2u);
    ++linked;
  }
  EXPECT_EQ(linked, 10);
  // An existing output is refused without overwrite.
  EXPECT_THROW(augmentDataset(options, newMarkers(), ProgressReporter()), Error);
  options.overwrite = true;
  EXPECT_NO_THROW(augmentDataset(options, newMarkers(), ProgressReporter()));
}

TEST_F(AugmentTest, StopOrBadRecordsChangeNothing) {
  const fs::path input = writeSample(dir_ / "sample.rawlog", DatasetKind::kRawlog);
  const auto before = snapshot();
  ProgressReporter stopped;
  stopped.requestStop();
  AugmentOptions options;
  options.input = input;
  EXPECT_THROW(augmentDataset(options, newMarkers(), stopped), StopRequested);
  EXPECT_EQ(snapshot(), before);

  std::vector<Record> bad = newMarkers();
  std::get<MarkerObservation>(bad[3]).camera = "cam99";
  try {
    augmentDataset(options, bad, ProgressReporter());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cam99"), std::string::npos) << e.what();
  }
  EXPECT_EQ(snapshot(), before);
}

TEST_F(AugmentTest, MergeJoinsShardsAndWritesSharedRecordsOnce) {
  const fs::path input = writeSample(dir_ / "sample.rawlog", DatasetKind::kRawlog);
  const std::size_t base = readAll(input).size();
  // Shard a adds markers of cam00, shard b blobs of the fisheye.
  AugmentOptions a;
  a.input = input;
  a.output = dir_ / "a.rawlog";
  augmentDataset(a, newMarkers(), ProgressReporter());
  std::vector<Record> blobs;
  for (int i = 0; i < 5; ++i) {
    BlobObservation b;
    b.t = secondsToNs(1700000000) + i * 700;  // rawlog stamps: 100 ns ticks
    b.camera = "fisheye";
    b.blobs = {{1.0 + i, 2.0, 3.0, 0.5}};
    blobs.push_back(b);
  }
  AugmentOptions b = a;
  b.output = dir_ / "b.rawlog";
  augmentDataset(b, blobs, ProgressReporter());

  MergeOptions merge;
  merge.inputs = {dir_ / "a.rawlog", dir_ / "b.rawlog"};
  merge.output = dir_ / "merged.rawlog";
  const MergeSummary summary = mergeDatasets(merge, ProgressReporter());
  EXPECT_EQ(summary.duplicates, static_cast<std::int64_t>(base));
  const std::vector<Record> merged = readAll(merge.output);
  EXPECT_EQ(merged.size(), base + 10 + 5);
  int with_corners = 0;
  for (std::size_t i = 1; i < merged.size(); ++i) {
    EXPECT_LE(recordTime(merged[i - 1]), recordTime(merged[i])) << i;
  }
  for (const Record& r : merged) {
    const auto* m = std::get_if<MarkerObservation>(&r);
    with_corners += m && m->corners_px.size() == 4;
  }
  EXPECT_EQ(with_corners, 5);  // augmenting and merging keep the input markers' corners
}

// Edge nodes' results: each input holds some of the cameras. The merge lists
// them all (the fisheye first) with their ground truth; a camera calibrated
// differently in two inputs, or another marker, is refused by name.
TEST_F(AugmentTest, MergeJoinsInputsOfSomeCamerasAndRefusesDisagreements) {
  auto write = [&](const std::vector<std::string>& labels) {
    Manifest m = testing::sampleManifest();
    std::vector<CameraSensor> kept;
    for (const CameraSensor& c : m.cameras)
      if (std::find(labels.begin(), labels.end(), c.label) != labels.end()) kept.push_back(c);
    m.cameras = kept;
    for (const char* label : {"cam00", "cam01"}) {
      if (!m.findCamera(label)) {
        m.ground_truth.world_from_camera.erase(label);
        m.ground_truth.clock_offset.erase(label);
        m.ground_truth.hidden_from_fisheye.erase(label);
      }
    }
    if (!m.fisheye()) m.ground_truth.fisheye_from_marker.reset();
    return m;
  };
  const Manifest cam01 = write({"cam01"});
  DatasetWriter::create(dir_ / "a.rawlog", DatasetKind::kRawlog, write({"cam00"}))->finish();
  DatasetWriter::create(dir_ / "b.rawlog", DatasetKind::kRawlog, cam01)->finish();
  DatasetWriter::create(dir_ / "f.rawlog", DatasetKind::kRawlog, write({"fisheye"}))->finish();
  MergeOptions merge;
  merge.inputs = {dir_ / "a.rawlog", dir_ / "b.rawlog", dir_ / "f.rawlog"};
  merge.output = dir_ / "merged.rawlog";
  mergeDatasets(merge, ProgressReporter());
  const Manifest merged = DatasetReader::open(merge.output)->manifest();
  ASSERT_EQ(merged.cameras.size(), 3u);
  EXPECT_EQ(merged.cameras[0].label, "fisheye");
  EXPECT_EQ(merged.cameras[1].label, "cam00");
  EXPECT_EQ(merged.cameras[2].label, "cam01");
  EXPECT_EQ(merged.ground_truth.world_from_camera.size(), 2u);
  EXPECT_EQ(merged.ground_truth.clock_offset.size(), 2u);
  EXPECT_EQ(merged.ground_truth.hidden_from_fisheye.at("cam01").size(), 2u);
  EXPECT_TRUE(merged.ground_truth.fisheye_from_marker.has_value());

  auto refused = [&](const Manifest& other, const std::string& expected) {
    DatasetWriter::create(dir_ / "other.rawlog", DatasetKind::kRawlog, other,
                          DatasetWriteOptions{true})
        ->finish();
    MergeOptions bad;
    bad.inputs = {dir_ / "b.rawlog", dir_ / "other.rawlog"};
    bad.output = dir_ / "refused.rawlog";
    try {
      mergeDatasets(bad, ProgressReporter());
      ADD_FAILURE() << "no error for " << expected;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(bad.output));
  };
  Manifest recalibrated = cam01;
  recalibrated.cameras[0].camera =
      loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/ceiling_camera_ros.yaml");
  refused(recalibrated, "'cameras': differs from the same camera");
  Manifest other_marker = cam01;
  other_marker.marker.id = 3;
  refused(other_marker, "'marker': another marker");
}

}  // namespace
}  // namespace lookboth
