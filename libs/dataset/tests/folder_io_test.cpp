// Tests of the plain-folder dataset format (doc/formats.md, "Dataset folder
// format"): reading the sample in tests/data/datasets/folder_small, writing
// and reading back, and one broken copy of the sample per bad case, each
// checking that the message names the file, the line and the column.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <map>

#include "lookboth/core/error.h"
#include "test_dataset.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

constexpr TimeNs kT0 = 1'000'000'000;  // first timestamp of the sample [ns]

fs::path sampleFolder() { return fs::path(LOOKBOTH_TEST_DATA_DIR) / "datasets" / "folder_small"; }

std::string readText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

void writeText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  ASSERT_TRUE(out.good()) << path;
}

/// Replaces the first occurrence of `from` in the file (which must hold it).
void replaceInFile(const fs::path& path, const std::string& from, const std::string& to) {
  std::string text = readText(path);
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << "'" << from << "' not in " << path;
  text.replace(at, from.size(), to);
  writeText(path, text);
}

void appendToFile(const fs::path& path, const std::string& text) {
  writeText(path, readText(path) + text);
}

/// Checks that `text` contains every needle.
void expectContains(const std::string& text, const std::vector<std::string>& needles) {
  for (const std::string& needle : needles) {
    EXPECT_NE(text.find(needle), std::string::npos) << "'" << needle << "' not in: " << text;
  }
}

struct ReadResult {
  Manifest manifest;
  std::vector<Record> records;
  std::vector<DatasetIssue> issues;
};

ReadResult readAll(const fs::path& folder, const DatasetReadOptions& options = {}) {
  ReadResult result;
  auto reader = DatasetReader::open(folder, options);
  EXPECT_EQ(reader->kind(), DatasetKind::kFolder);
  result.manifest = reader->manifest();
  while (auto record = reader->next()) result.records.push_back(std::move(*record));
  result.issues = reader->issues();
  return result;
}

template <typename T>
std::vector<T> recordsOf(const std::vector<Record>& records, const std::string& label = "") {
  std::vector<T> out;
  for (const Record& record : records) {
    if (const T* r = std::get_if<T>(&record);
        r && (label.empty() || recordLabel(record) == label)) {
      out.push_back(*r);
    }
  }
  return out;
}

void expectSamePose(const Rigid3d& a, const Rigid3d& b, double tolerance = 1e-15) {
  EXPECT_LE((a.translation - b.translation).norm(), tolerance);
  EXPECT_LE((a.rotation.coeffs() - b.rotation.coeffs()).norm(), tolerance);
}

class FolderIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("lookboth_folder_io_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  /// A copy of the sample to break; `folder` / relative path of a file.
  fs::path copySample() {
    const fs::path copy = dir_ / "folder_small";
    fs::copy(sampleFolder(), copy, fs::copy_options::recursive);
    return copy;
  }

  /// Opens and reads `folder`; expects a lookboth::Error whose message holds
  /// every needle. Returns the message.
  std::string expectReadError(const fs::path& folder, const std::vector<std::string>& needles,
                              const DatasetReadOptions& options = {}) {
    try {
      readAll(folder, options);
    } catch (const Error& error) {
      expectContains(error.what(), needles);
      return error.what();
    } catch (const std::exception& other) {
      ADD_FAILURE() << "not a lookboth::Error: " << other.what();
      return "";
    }
    ADD_FAILURE() << "no error reading " << folder;
    return "";
  }

  std::vector<std::string> entries(const fs::path& directory) const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(directory)) {
      names.push_back(e.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
  }

  fs::path dir_;
};

// ---------------------------------------------------------------------------
// The good sample

TEST_F(FolderIoTest, ReadsTheSampleManifest) {
  const ReadResult result = readAll(sampleFolder());
  const Manifest& m = result.manifest;
  EXPECT_EQ(m.name, "folder_small");
  EXPECT_EQ(m.marker.dictionary, "DICT_4X4_50");
  EXPECT_EQ(m.marker.id, 7);
  EXPECT_EQ(m.marker.size_m, 0.15);
  EXPECT_EQ(m.check(), "");

  ASSERT_EQ(m.cameras.size(), 3u);
  EXPECT_EQ(m.cameras[0].label, "fisheye");
  EXPECT_EQ(m.cameras[0].role, SensorRole::kFisheye);
  ASSERT_TRUE(m.cameras[0].camera);
  EXPECT_EQ(m.cameras[0].camera->modelName(), "scaramuzza");  // OCamCalib
  EXPECT_EQ(m.cameras[0].camera->width(), 64);
  EXPECT_EQ(m.cameras[0].camera->height(), 48);
  EXPECT_EQ(m.cameras[0].camera->params()[0], 32.2547);  // cx = column
  EXPECT_EQ(m.cameras[1].label, "cam_a");                // ROS camera_info
  EXPECT_EQ(m.cameras[1].role, SensorRole::kEnvCamera);
  ASSERT_TRUE(m.cameras[1].camera);
  EXPECT_EQ(m.cameras[1].camera->modelName(), "radtan");
  EXPECT_EQ(m.cameras[1].camera->params()[0], 30.5);
  EXPECT_EQ(m.cameras[2].label, "cam_b");  // Kalibr camchain: its first camera (cam0)
  ASSERT_TRUE(m.cameras[2].camera);
  EXPECT_EQ(m.cameras[2].camera->width(), 32);
  EXPECT_EQ(m.cameras[2].camera->params()[1], 28.5);

  ASSERT_EQ(m.trajectories.size(), 3u);
  EXPECT_EQ(m.trajectories[0].label, "odometry");
  EXPECT_FALSE(m.trajectories[0].metric);
  EXPECT_EQ(m.trajectories[0].description, "wheel odometry, scale unknown");
  EXPECT_EQ(m.trajectories[1].label, "ground_truth");
  EXPECT_TRUE(m.trajectories[1].metric);
  EXPECT_EQ(m.trajectories[2].label, "vo");
  EXPECT_FALSE(m.trajectories[2].metric);
  EXPECT_EQ(m.trajectories[2].description, "monocular VO");

  const GroundTruth& truth = m.ground_truth;
  ASSERT_EQ(truth.world_from_camera.size(), 2u);
  EXPECT_EQ(truth.world_from_camera.at("cam_a").translation, Eigen::Vector3d(2, 3, 3));
  EXPECT_EQ(truth.world_from_camera.at("cam_a").rotation.coeffs(), Eigen::Vector4d(1, 0, 0, 0));
  EXPECT_NEAR(truth.world_from_camera.at("cam_b").rotation.x(), std::sqrt(0.5), 1e-15);
  ASSERT_TRUE(truth.fisheye_from_marker);
  EXPECT_EQ(truth.fisheye_from_marker->translation, Eigen::Vector3d(0, 0.05, -0.3));
  EXPECT_EQ(truth.clock_offset, (std::map<std::string, TimeNs>{{"cam_a", 1500}, {"cam_b", -2000}}));
}

TEST_F(FolderIoTest, ReadsTheSampleRecordsInTimeOrder) {
  const ReadResult result = readAll(sampleFolder());
  EXPECT_TRUE(result.issues.empty())
      << result.issues.front().where << ": " << result.issues.front().message;
  const std::vector<Record>& records = result.records;
  ASSERT_EQ(records.size(), 23u);
  EXPECT_EQ(recordsOf<ImageFrame>(records, "fisheye").size(), 3u);
  EXPECT_EQ(recordsOf<ImageFrame>(records, "cam_a").size(), 2u);
  EXPECT_EQ(recordsOf<ImageFrame>(records, "cam_b").size(), 2u);
  EXPECT_EQ(recordsOf<MarkerObservation>(records).size(), 3u);
  EXPECT_EQ(recordsOf<BlobObservation>(records).size(), 3u);
  EXPECT_EQ(recordsOf<PoseSample>(records, "odometry").size(), 4u);
  EXPECT_EQ(recordsOf<PoseSample>(records, "ground_truth").size(), 3u);
  EXPECT_EQ(recordsOf<PoseSample>(records, "vo").size(), 3u);

  for (size_t i = 1; i < records.size(); ++i) {
    EXPECT_LE(recordTime(records[i - 1]), recordTime(records[i])) << "record " << i;
  }
  // Ties are broken in the documented order: fisheye frames, environment
  // camera frames by label, blobs, markers, odometry, ground truth, others.
  std::vector<std::string> at_t0;
  for (const Record& record : records) {
    if (recordTime(record) == kT0) {
      at_t0.push_back(std::string(recordKindName(record)) + ":" + recordLabel(record));
    }
  }
  EXPECT_EQ(at_t0, (std::vector<std::string>{"image:fisheye", "image:cam_a", "blobs:fisheye",
                                             "marker:cam_a", "pose:ground_truth", "pose:vo"}));

  const auto frames = recordsOf<ImageFrame>(records, "cam_b");
  EXPECT_EQ(frames[0].t, 1'050'000'000);
  EXPECT_TRUE(frames[0].image_file.is_absolute());
  EXPECT_EQ(frames[0].image_file.filename(), "b_000.png");
  EXPECT_TRUE(fs::exists(frames[0].image_file));

  const auto markers = recordsOf<MarkerObservation>(records);
  EXPECT_EQ(markers[0].information, (Eigen::Matrix<double, 6, 6>::Zero()));  // no information given
  const MarkerObservation& m1 = markers[1];
  EXPECT_EQ(m1.t, 1'050'000'000);
  EXPECT_EQ(m1.camera, "cam_b");
  EXPECT_EQ(m1.marker_id, 7);
  EXPECT_EQ(m1.camera_from_marker.translation, Eigen::Vector3d(-0.3, 0.05, 2.25));
  EXPECT_NEAR(m1.camera_from_marker.rotation.w(), std::sqrt(0.5), 1e-15);
  EXPECT_EQ(m1.information(0, 0), 100);
  EXPECT_EQ(m1.information(0, 1), 1);
  EXPECT_EQ(m1.information(1, 0), 1);
  EXPECT_EQ(m1.information(5, 5), 400);
  EXPECT_EQ(m1.information(2, 4), 0);

  const auto blobs = recordsOf<BlobObservation>(records);
  ASSERT_EQ(blobs[0].blobs.size(), 2u);
  EXPECT_EQ(blobs[0].camera, "fisheye");
  EXPECT_EQ(blobs[0].image_width, 64);
  EXPECT_EQ(blobs[0].image_height, 48);
  EXPECT_EQ(blobs[0].blobs[1].u, 40);
  EXPECT_EQ(blobs[0].blobs[1].v, 12);
  EXPECT_EQ(blobs[0].blobs[1].diameter_px, 3.5);
  EXPECT_EQ(blobs[0].blobs[1].response, 0.6);
  EXPECT_EQ(blobs[1].t, 1'100'000'000);
  EXPECT_TRUE(blobs[1].blobs.empty());  // a frame in which no blob was found
  EXPECT_EQ(blobs[1].image_width, 64);

  const auto odometry = recordsOf<PoseSample>(records, "odometry");
  EXPECT_EQ(odometry[2].t, 1'150'000'000);  // 1.15 s, exactly
  EXPECT_EQ(odometry[2].world_from_body.translation, Eigen::Vector3d(0.2, 0.01, 0.5));
  EXPECT_NEAR(odometry[2].world_from_body.rotation.z(), 0.0499791692706783, 1e-15);
}

TEST_F(FolderIoTest, MarkerYamlIsEnough) {
  const fs::path folder = dir_ / "minimal";
  fs::create_directories(folder);
  writeText(folder / "marker.yaml", "dictionary: DICT_APRILTAG_36h11\nid: 3\nsize_m: 0.2\n");
  const ReadResult result = readAll(folder);
  EXPECT_TRUE(result.records.empty());
  EXPECT_TRUE(result.manifest.cameras.empty());
  EXPECT_TRUE(result.manifest.trajectories.empty());
  EXPECT_EQ(result.manifest.marker.dictionary, "DICT_APRILTAG_36h11");
}

TEST_F(FolderIoTest, OdometryIsMetricWithoutOdometryYaml) {
  const fs::path folder = copySample();
  fs::remove(folder / "odometry/odometry.yaml");
  const ReadResult result = readAll(folder);
  ASSERT_TRUE(result.manifest.findTrajectory("odometry"));
  EXPECT_TRUE(result.manifest.findTrajectory("odometry")->metric);
}

TEST_F(FolderIoTest, SmallQuaternionDeviationsAreNormalised) {
  const fs::path folder = copySample();
  replaceInFile(folder / "detections/markers.csv", "0.1,-0.2,2.5,0,0,0,1,",
                "0.1,-0.2,2.5,0,0,0,1.0005,");
  const auto markers = recordsOf<MarkerObservation>(readAll(folder).records);
  EXPECT_NEAR(markers[0].camera_from_marker.rotation.norm(), 1.0, 1e-15);
}

// ---------------------------------------------------------------------------
// Writing

TEST_F(FolderIoTest, FolderToFolderRoundTripIsLossless) {
  const ReadResult original = readAll(sampleFolder());
  fs::create_directories(dir_ / "out");
  const fs::path copy = dir_ / "out" / "folder_small";  // same name: same manifest name
  {
    auto writer = DatasetWriter::create(copy, DatasetKind::kFolder, original.manifest);
    for (const Record& record : original.records) writer->write(record);
    EXPECT_EQ(writer->recordsWritten(), 23);
    writer->finish();
  }
  EXPECT_EQ(entries(dir_ / "out"), std::vector<std::string>{"folder_small"});  // no leftovers
  // Calibrations are rewritten as lookboth YAML; images keep their bytes.
  EXPECT_NE(readText(copy / "fisheye/calibration.yaml").find("lookboth_camera: 1"),
            std::string::npos);
  EXPECT_TRUE(fs::exists(copy / "cameras/cam_b/frames" / "1050000000.png"));

  const ReadResult again = readAll(copy);
  EXPECT_TRUE(again.issues.empty());
  EXPECT_EQ(manifestToYaml(again.manifest), manifestToYaml(original.manifest));
  ASSERT_EQ(again.manifest.cameras.size(), original.manifest.cameras.size());
  for (size_t i = 0; i < original.manifest.cameras.size(); ++i) {
    const CameraSensor& a = original.manifest.cameras[i];
    const CameraSensor& b = again.manifest.cameras[i];
    EXPECT_EQ(a.label, b.label);
    EXPECT_EQ(a.role, b.role);
    EXPECT_EQ(a.camera->modelName(), b.camera->modelName());
    EXPECT_EQ(a.camera->params(), b.camera->params());  // bit-identical
    EXPECT_EQ(a.camera->width(), b.camera->width());
  }
  for (size_t i = 0; i < original.manifest.trajectories.size(); ++i) {
    EXPECT_EQ(again.manifest.trajectories[i].label, original.manifest.trajectories[i].label);
    EXPECT_EQ(again.manifest.trajectories[i].metric, original.manifest.trajectories[i].metric);
    EXPECT_EQ(again.manifest.trajectories[i].description,
              original.manifest.trajectories[i].description);
  }
  EXPECT_EQ(again.manifest.ground_truth.clock_offset, original.manifest.ground_truth.clock_offset);
  expectSamePose(*again.manifest.ground_truth.fisheye_from_marker,
                 *original.manifest.ground_truth.fisheye_from_marker, 0.0);
  for (const auto& [label, pose] : original.manifest.ground_truth.world_from_camera) {
    expectSamePose(again.manifest.ground_truth.world_from_camera.at(label), pose, 0.0);
  }

  ASSERT_EQ(again.records.size(), original.records.size());
  for (size_t i = 0; i < original.records.size(); ++i) {
    EXPECT_TRUE(testing::sameRecord(again.records[i], original.records[i])) << "record " << i;
    if (const auto* a = std::get_if<BlobObservation>(&original.records[i])) {
      const auto& b = std::get<BlobObservation>(again.records[i]);
      EXPECT_EQ(a->image_width, b.image_width);
      EXPECT_EQ(a->image_height, b.image_height);
    }
    if (const auto* a = std::get_if<MarkerObservation>(&original.records[i])) {
      // Marker poses and information are written and read exactly.
      const auto& b = std::get<MarkerObservation>(again.records[i]);
      expectSamePose(a->camera_from_marker, b.camera_from_marker, 0.0);
      EXPECT_EQ(a->information, b.information);
    }
    if (const auto* a = std::get_if<PoseSample>(&original.records[i])) {
      expectSamePose(a->world_from_body, std::get<PoseSample>(again.records[i]).world_from_body);
    }
  }
}

TEST_F(FolderIoTest, WritesEncodedImagesAndSyntheticRecords) {
  const Manifest manifest = testing::sampleManifest();
  const std::vector<Record> records = testing::sampleRecords();
  const fs::path folder = dir_ / "sample";
  {
    auto writer = DatasetWriter::create(folder, DatasetKind::kFolder, manifest);
    for (const Record& record : records) writer->write(record);
    writer->finish();
  }
  // The synthetic PNGs are 32x24, the calibrations are not: not checked here.
  DatasetReadOptions options;
  options.check_images = false;
  const ReadResult result = readAll(folder, options);
  EXPECT_EQ(manifestToYaml(result.manifest), manifestToYaml(manifest));
  ASSERT_EQ(result.records.size(), records.size());
  for (size_t i = 0; i < records.size(); ++i) {
    EXPECT_TRUE(testing::sameRecord(result.records[i], records[i])) << "record " << i;
  }
  EXPECT_TRUE(
      fs::exists(folder / "fisheye/frames" / (std::to_string(recordTime(records[2])) + ".png")));
}

TEST_F(FolderIoTest, MarkerCornersRoundTripExactlyAndOldFilesReadWithout) {
  const std::vector<Record> records = testing::withCorners(testing::sampleRecords());
  const fs::path folder = dir_ / "sample";
  {
    auto writer = DatasetWriter::create(folder, DatasetKind::kFolder, testing::sampleManifest());
    for (const Record& record : records) writer->write(record);
    writer->finish();
  }
  DatasetReadOptions options;
  options.check_images = false;
  const ReadResult result = readAll(folder, options);
  ASSERT_EQ(result.records.size(), records.size());
  int with_corners = 0;
  for (size_t i = 0; i < records.size(); ++i) {
    EXPECT_TRUE(testing::sameRecord(result.records[i], records[i])) << "record " << i;
    if (const auto* m = std::get_if<MarkerObservation>(&result.records[i]))
      with_corners += !m->corners_px.empty();
  }
  EXPECT_EQ(with_corners, 5);
  expectContains(readText(folder / "detections/markers.csv"),
                 {"qw,information,corners,corner_sigma_px\n", ",,\n"});
  // The shipped sample has neither column: no corners, no noise.
  for (const auto& m : recordsOf<MarkerObservation>(readAll(sampleFolder()).records)) {
    EXPECT_TRUE(m.corners_px.empty());
    EXPECT_EQ(m.corner_sigma_px, 0.0);
  }
}

TEST_F(FolderIoTest, BadCornersAreErrorsNamingFileLineAndColumn) {
  const fs::path folder = copySample();
  const fs::path markers = folder / "detections/markers.csv";
  const std::string header =
      "timestamp_ns,camera,marker_id,tx,ty,tz,qx,qy,qz,qw,corners,corner_sigma_px\n";
  const std::string good = "1000000000,cam_a,7,0.1,-0.2,2.5,0,0,0,1,1 2 3 4 5 6 7 8,0.2\n";
  writeText(markers, header + good + "1050000000,cam_b,7,0,0,2,0,0,0,1,,\n");
  const ReadResult ok = readAll(folder);
  const auto read = recordsOf<MarkerObservation>(ok.records);
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].corners_px, (std::vector<Eigen::Vector2d>{{1, 2}, {3, 4}, {5, 6}, {7, 8}}));
  EXPECT_EQ(read[0].corner_sigma_px, 0.2);
  EXPECT_TRUE(read[1].corners_px.empty());  // empty cells: none
  writeText(markers, header + good + "1050000000,cam_b,7,0,0,2,0,0,0,1,1 2 3 4 5 6 7,\n");
  expectReadError(folder,
                  {"markers.csv:3: 'corners': expected 8 space-separated numbers", "got 7"});
  writeText(markers, header + good + "1050000000,cam_b,7,0,0,2,0,0,0,1,1 2 3 x 5 6 7 8,\n");
  expectReadError(folder, {"markers.csv:3: 'corners': value 4 'x' is not a finite number"});
  writeText(markers, header + good + "1050000000,cam_b,7,0,0,2,0,0,0,1,1 2 3 4 5 6 7 nan,\n");
  expectReadError(folder, {"markers.csv:3: 'corners': value 8 'nan' is not a finite number"});
  writeText(markers, header + good + "1050000000,cam_b,7,0,0,2,0,0,0,1,,-0.5\n");
  expectReadError(folder, {"markers.csv:3: 'corner_sigma_px': negative corner noise"});
  writeText(markers, header + good + "1050000000,cam_b,7,0,0,2,0,0,0,1,,abc\n");
  expectReadError(folder, {"markers.csv:3: 'corner_sigma_px'"});
}

TEST_F(FolderIoTest, WriterRefusesAnExistingOutputWithoutOverwrite) {
  const Manifest manifest = readAll(sampleFolder()).manifest;
  const fs::path folder = dir_ / "existing";
  fs::create_directories(folder);
  writeText(folder / "keep.txt", "precious");
  try {
    DatasetWriter::create(folder, DatasetKind::kFolder, manifest);
    ADD_FAILURE() << "no error";
  } catch (const Error& error) {
    expectContains(error.what(), {folder.string(), "already exists"});
  }
  EXPECT_EQ(readText(folder / "keep.txt"), "precious");
  EXPECT_EQ(entries(dir_), std::vector<std::string>{"existing"});
}

TEST_F(FolderIoTest, WriterLeavesNothingBehindWithoutFinish) {
  const ReadResult original = readAll(sampleFolder());
  {
    auto writer =
        DatasetWriter::create(dir_ / "unfinished", DatasetKind::kFolder, original.manifest);
    for (const Record& record : original.records) writer->write(record);
  }
  EXPECT_TRUE(entries(dir_).empty());
}

TEST_F(FolderIoTest, WriterOverwriteReplacesTheFolder) {
  const ReadResult original = readAll(sampleFolder());
  const fs::path folder = dir_ / "replaced";
  fs::create_directories(folder);
  writeText(folder / "old.txt", "old");
  DatasetWriteOptions options;
  options.overwrite = true;
  auto writer = DatasetWriter::create(folder, DatasetKind::kFolder, original.manifest, options);
  for (const Record& record : original.records) writer->write(record);
  EXPECT_TRUE(fs::exists(folder / "old.txt"));  // replaced only by finish()
  writer->finish();
  EXPECT_FALSE(fs::exists(folder / "old.txt"));
  EXPECT_EQ(readAll(folder).records.size(), original.records.size());
  EXPECT_EQ(entries(dir_), std::vector<std::string>{"replaced"});
}

TEST_F(FolderIoTest, WriterRefusesWhatTheFormatCannotHold) {
  Manifest manifest = readAll(sampleFolder()).manifest;
  Manifest uncalibrated = manifest;
  uncalibrated.cameras[1].camera.reset();
  try {
    DatasetWriter::create(dir_ / "a", DatasetKind::kFolder, uncalibrated);
    ADD_FAILURE() << "no error";
  } catch (const Error& error) {
    expectContains(error.what(), {"calibration", "cam_a"});
  }
  auto writer = DatasetWriter::create(dir_ / "b", DatasetKind::kFolder, manifest);
  ImageFrame frame;
  frame.t = 5;
  frame.sensor = "cam_zz";
  frame.image_file = sampleFolder() / "cameras/cam_b/b_000.png";
  try {
    writer->write(frame);
    ADD_FAILURE() << "no error";
  } catch (const Error& error) {
    expectContains(error.what(), {"cam_zz", "manifest does not list"});
  }
  frame.sensor = "cam_b";
  frame.image_file = dir_ / "no_such.png";
  try {
    writer->write(frame);
    ADD_FAILURE() << "no error";
  } catch (const Error& error) {
    expectContains(error.what(), {"no_such.png", "cannot copy"});
  }
}

// ---------------------------------------------------------------------------
// Bad input: errors

TEST_F(FolderIoTest, MissingMarkerYamlIsAnError) {
  const fs::path folder = copySample();
  fs::remove(folder / "marker.yaml");
  expectReadError(folder, {"marker.yaml", "missing"});
}

TEST_F(FolderIoTest, UnknownDictionaryIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "marker.yaml", "DICT_4X4_50", "DICT_9X9_50");
  expectReadError(folder, {"marker.yaml", "'dictionary'", "DICT_9X9_50"});
}

TEST_F(FolderIoTest, BadMarkerYamlIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "marker.yaml", "size_m: 0.15", "size: 0.15");
  expectReadError(folder, {"marker.yaml:4: 'size': unknown key"});
  replaceInFile(folder / "marker.yaml", "size: 0.15", "size_m: big");
  expectReadError(folder, {"marker.yaml:4: 'size_m': expected a finite number, got 'big'"});
}

TEST_F(FolderIoTest, MissingRequiredColumnIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "detections/markers.csv", "qz,qw,note", "qz,q_w,note");
  expectReadError(folder, {"markers.csv:2: 'qw': required column is missing"});
}

TEST_F(FolderIoTest, MissingFileColumnInFramesIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "cameras/cam_b/frames.csv", "timestamp_ns,file", "timestamp_ns,path");
  expectReadError(folder, {"cam_b", "frames.csv:1: 'file': required column is missing"});
}

TEST_F(FolderIoTest, BadNumberIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "detections/markers.csv", "1000000000,cam_a,7,0.1,",
                "1000000000,cam_a,7,0.1x,");
  expectReadError(folder, {"markers.csv:3: 'tx': not a number: '0.1x'"});
}

TEST_F(FolderIoTest, BadTimestampIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "fisheye/frames.csv", "1100000000,", "1.1e9,");
  expectReadError(folder, {"fisheye", "frames.csv:3: 'timestamp_ns': not an integer: '1.1e9'"});
}

TEST_F(FolderIoTest, NanIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "detections/blobs.csv", "1000000000,40,", "1000000000,nan,");
  expectReadError(folder, {"blobs.csv:3: 'u': NaN"});
}

TEST_F(FolderIoTest, InfinityIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "ground_truth/cameras.csv", "cam_a,2,", "cam_a,inf,");
  expectReadError(folder, {"cameras.csv:2: 'tx': infinite value 'inf'"});
}

TEST_F(FolderIoTest, ShortRowIsAnError) {
  const fs::path folder = copySample();
  appendToFile(folder / "ground_truth/clock_offsets.csv", "vo\n");
  expectReadError(folder, {"clock_offsets.csv:4: expected 2 comma-separated fields"});
}

TEST_F(FolderIoTest, NonUnitQuaternionIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "detections/markers.csv", "0.1,-0.2,2.5,0,0,0,1,",
                "0.1,-0.2,2.5,0,0,0,1.01,");
  expectReadError(folder,
                  {"markers.csv:3: 'qx,qy,qz,qw': quaternion (qx qy qz qw) has norm 1.010000"});
}

TEST_F(FolderIoTest, NonUnitQuaternionInTumIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "ground_truth/trajectory.tum", "1.1 1.1 2 0.5 0 0 0 1",
                "1.1 1.1 2 0.5 0 0 0 2");
  expectReadError(folder, {"ground_truth", "trajectory.tum:2", "norm 2.000000"});
}

TEST_F(FolderIoTest, NonUnitQuaternionInFisheyeFromMarkerIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "ground_truth/fisheye_from_marker.yaml", "qx: 1", "qx: 0.5");
  expectReadError(folder, {"fisheye_from_marker.yaml:4: 'qx': quaternion", "norm 0.500000"});
}

TEST_F(FolderIoTest, BadInformationIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "detections/markers.csv", "100 1 0", "100 1");
  expectReadError(folder,
                  {"markers.csv:4: 'information': expected 21 space-separated numbers", "got 20"});
}

TEST_F(FolderIoTest, UnknownCameraInMarkersIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "detections/markers.csv", "1200000000,cam_a,", "1200000000,cam_z,");
  const std::string message = expectReadError(
      folder,
      {"markers.csv:5: 'camera': unknown camera 'cam_z' (environment cameras: cam_a, cam_b)"});
}

TEST_F(FolderIoTest, UnknownCameraInGroundTruthIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "ground_truth/cameras.csv", "cam_b,", "cam_c,");
  expectReadError(folder, {"cameras.csv:3: 'label': 'cam_c' is not an environment camera"});
}

TEST_F(FolderIoTest, CameraFolderWithoutCalibrationIsAnError) {
  const fs::path folder = copySample();
  fs::remove(folder / "cameras/cam_b/calibration.yaml");
  expectReadError(folder,
                  {(folder / "cameras/cam_b").string() + ": camera folder without a calibration"});
}

TEST_F(FolderIoTest, FisheyeWithTwoCalibrationsIsAnError) {
  const fs::path folder = copySample();
  fs::copy_file(folder / "cameras/cam_a/calibration.yaml", folder / "fisheye/calibration.yaml");
  expectReadError(folder, {"fisheye: several calibration files"});
}

TEST_F(FolderIoTest, BadCalibrationNamesItsFile) {
  const fs::path folder = copySample();
  replaceInFile(folder / "cameras/cam_a/calibration.yaml", "distortion_model: plumb_bob",
                "distortion_model: fov");
  expectReadError(folder, {"cam_a", "calibration.yaml", "fov"});
}

TEST_F(FolderIoTest, BlobsWithoutFisheyeIsAnError) {
  const fs::path folder = copySample();
  fs::remove_all(folder / "fisheye");
  expectReadError(folder, {"blobs.csv", "no fisheye"});
}

TEST_F(FolderIoTest, BadMetricIsAnError) {
  const fs::path folder = copySample();
  replaceInFile(folder / "odometry/odometry.yaml", "metric: false", "metric: maybe");
  expectReadError(folder, {"odometry.yaml:1: 'metric': expected true or false, got 'maybe'"});
}

// ---------------------------------------------------------------------------
// Bad input: issues (the record is skipped; an error in strict mode)

TEST_F(FolderIoTest, MissingImageIsSkippedWithAnIssue) {
  const fs::path folder = copySample();
  fs::remove(folder / "fisheye/frames/f001.png");
  const ReadResult result = readAll(folder);
  EXPECT_EQ(recordsOf<ImageFrame>(result.records, "fisheye").size(), 2u);
  ASSERT_EQ(result.issues.size(), 1u);
  expectContains(result.issues[0].where, {"fisheye", "frames.csv:3"});
  expectContains(result.issues[0].message, {"f001.png", "does not exist", "skipped"});

  DatasetReadOptions strict;
  strict.strict = true;
  expectReadError(folder, {"frames.csv:3", "f001.png", "does not exist"}, strict);
}

TEST_F(FolderIoTest, UnreadableImageIsSkippedWithAnIssue) {
  const fs::path folder = copySample();
  writeText(folder / "cameras/cam_a/img/a_000.png", "not a png");
  const ReadResult result = readAll(folder);
  EXPECT_EQ(recordsOf<ImageFrame>(result.records, "cam_a").size(), 1u);
  ASSERT_EQ(result.issues.size(), 1u);
  expectContains(result.issues[0].where, {"cam_a", "frames.csv:3"});
  expectContains(result.issues[0].message, {"cannot decode", "a_000.png"});
}

TEST_F(FolderIoTest, ImageSizeDifferentFromCalibrationIsAnIssue) {
  const fs::path folder = copySample();
  replaceInFile(folder / "cameras/cam_a/calibration.yaml", "image_width: 32", "image_width: 40");
  replaceInFile(folder / "cameras/cam_a/calibration.yaml", "image_height: 24", "image_height: 30");
  const ReadResult result = readAll(folder);
  ASSERT_EQ(result.issues.size(), 1u);  // checked on the first frame of each camera only
  expectContains(result.issues[0].where, {"cam_a", "frames.csv:3"});
  expectContains(result.issues[0].message,
                 {"a_000.png", "is 32x24 px", "calibration of camera 'cam_a'", "is 40x30 px"});
  EXPECT_EQ(recordsOf<ImageFrame>(result.records, "cam_a").size(), 2u);  // frames are kept

  DatasetReadOptions strict;
  strict.strict = true;
  expectReadError(folder, {"frames.csv:3", "is 32x24 px"}, strict);
}

TEST_F(FolderIoTest, UnsortedAndDuplicatedFramesAreSkipped) {
  const fs::path folder = copySample();
  appendToFile(folder / "cameras/cam_b/frames.csv",
               "1150000000,b_000.png,800\n1100000000,b_001.png,800\n");
  const ReadResult result = readAll(folder);
  EXPECT_EQ(recordsOf<ImageFrame>(result.records, "cam_b").size(), 2u);
  ASSERT_EQ(result.issues.size(), 2u);
  expectContains(result.issues[0].where, {"cam_b", "frames.csv:4"});
  expectContains(result.issues[0].message, {"1150000000 repeats the previous one", "skipped"});
  expectContains(result.issues[1].where, {"frames.csv:5"});
  expectContains(result.issues[1].message, {"1100000000 is earlier than the previous one"});
}

TEST_F(FolderIoTest, DuplicatedMarkerRowIsSkipped) {
  const fs::path folder = copySample();
  appendToFile(folder / "detections/markers.csv", "1200000000,cam_a,7,0,0,2,0,0,0,1,,\n");
  const ReadResult result = readAll(folder);
  EXPECT_EQ(recordsOf<MarkerObservation>(result.records).size(), 3u);
  ASSERT_EQ(result.issues.size(), 1u);
  expectContains(result.issues[0].where, {"markers.csv:6"});
  expectContains(result.issues[0].message, {"camera 'cam_a' and marker 7"});
}

TEST_F(FolderIoTest, MarkersOfSeveralCamerasMayShareATimestamp) {
  const fs::path folder = copySample();
  appendToFile(folder / "detections/markers.csv", "1200000000,cam_b,7,0,0,2,0,0,0,1,,\n");
  const ReadResult result = readAll(folder);
  EXPECT_EQ(recordsOf<MarkerObservation>(result.records).size(), 4u);
  EXPECT_TRUE(result.issues.empty());
}

TEST_F(FolderIoTest, DuplicatedBlobFrameAndPoseAreSkipped) {
  const fs::path folder = copySample();
  appendToFile(folder / "detections/blobs.csv", "1100000000,1,2,3,,,\n");
  appendToFile(folder / "trajectories/vo.tum", "1.2 0.1 0 0 0 0 0 1\n");
  const ReadResult result = readAll(folder);
  EXPECT_EQ(recordsOf<BlobObservation>(result.records).size(), 3u);
  EXPECT_EQ(recordsOf<PoseSample>(result.records, "vo").size(), 3u);
  ASSERT_EQ(result.issues.size(), 2u);
  std::string all;
  for (const DatasetIssue& issue : result.issues) all += issue.where + ": " + issue.message + "\n";
  expectContains(all, {"blobs.csv:6: timestamp 1100000000 is earlier than the previous one",
                       "vo.tum:4: timestamp 1200000000 repeats the previous one"});
}

TEST_F(FolderIoTest, ErrorsKeepTheRecordsAlreadyRead) {
  const fs::path folder = copySample();
  appendToFile(folder / "trajectories/vo.tum", "1.3 0.1 0 0 0 0 0 1 7\n");
  auto reader = DatasetReader::open(folder);
  std::vector<Record> records;
  try {
    while (auto record = reader->next()) records.push_back(*record);
    ADD_FAILURE() << "no error";
  } catch (const Error& error) {
    expectContains(error.what(), {"vo.tum:4", "expected 8 values"});
  }
  // A stream reads its next row only when the merge needs it, i.e. after its
  // previous record (vo at 1.2 s) was returned: every record up to then is kept.
  ASSERT_EQ(records.size(), 22u);
  EXPECT_EQ(recordTime(records.back()), 1'200'000'000);
}

}  // namespace
}  // namespace lookboth
