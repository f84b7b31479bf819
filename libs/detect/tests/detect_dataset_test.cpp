#include "lookboth/detect/detect_dataset.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

#include "lookboth/core/error.h"
#include "lookboth/core/option_fields.h"
#include "lookboth/core/paths.h"
#include "lookboth/core/scoped_environment.h"
#include "lookboth/core/test_seed.h"
#include "lookboth/detect/detection_evaluation.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/simulate.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

/// A built-in scenario's YAML text.
std::string builtinScenarioText(const std::string& name) {
  std::ifstream in(sim::builtinScenarioDirectory() / (name + ".yaml"));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// `yaml` written as `file`, with its noise drawn from testSeed(its seed)
/// (later_drive.noise_seed) under a test seed offset: the same facility with
/// another realisation of every random error.
std::string writeScenario(const std::string& yaml, const fs::path& file) {
  std::string text = yaml;
  const std::uint32_t seed = sim::scenarioFromYaml(yaml, file.string(), file.parent_path()).seed;
  if (testSeed(seed) != seed) {
    text += "\nlater_drive:\n  noise_seed: " + std::to_string(testSeed(seed)) + "\n";
  }
  std::ofstream(file) << text;
  return file.string();
}

/// The first seconds of the `small` scenario, rendered once for all tests
/// (cam03 and cam04 see the robot from the start; 640x360 frames).
class DetectDatasetTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / "lookboth_detect_dataset_test";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    sim::SimulateOptions options;
    options.scenario = testSeedOffset() == 0 ? "small"
                                             : writeScenario(builtinScenarioText("small"),
                                                             dir_ / "small_scenario.yaml");
    options.out = dir_ / "small.rawlog";
    options.max_duration_s = 4.0;
    options.threads = 2;
    sim::simulate(options, ProgressReporter());
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::vector<Record> readAll(const fs::path& path) {
    auto reader = DatasetReader::open(path);
    std::vector<Record> records;
    while (auto r = reader->next()) records.push_back(*r);
    return records;
  }

  static fs::path dir_;
};
fs::path DetectDatasetTest::dir_;

TEST_F(DetectDatasetTest, AccuracyOnSmallAndThreadIndependence) {
  DetectOptions options;
  options.dataset = dir_ / "small.rawlog";
  options.config = defaultDetectConfig();
  options.threads = 1;
  DetectSummary one, two;
  const std::vector<Record> a = runDetection(options, ProgressReporter(), &one);
  options.threads = 2;
  const std::vector<Record> b = runDetection(options, ProgressReporter(), &two);
  // Deterministic whatever the thread count.
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(recordKey(a[i]), recordKey(b[i]));
    if (const auto* m = std::get_if<MarkerObservation>(&a[i])) {
      EXPECT_EQ(m->camera_from_marker.translation,
                std::get<MarkerObservation>(b[i]).camera_from_marker.translation);
    }
  }
  const GroundTruthView truth = loadGroundTruth(options.dataset);
  std::vector<MarkerObservation> markers;
  std::vector<BlobObservation> blobs;
  for (const Record& r : a) {
    if (const auto* m = std::get_if<MarkerObservation>(&r)) markers.push_back(*m);
    if (const auto* bl = std::get_if<BlobObservation>(&r)) blobs.push_back(*bl);
  }
  const MarkerEvaluation e = evaluateMarkers(truth, markers, one.searched, {0.0, 100.0});
  std::printf(
      "small, first 4 s: markers recall %d/%d, false positives %d, median %.2f mm, p90 "
      "%.2f mm, in-plane %.3f deg, tilt %.3f deg, mean NEES %.2f\n",
      e.detected_frames, e.visible_frames, e.false_positives, e.bands.back().median_position_mm,
      e.bands.back().p90_position_mm, e.bands.back().median_in_plane_deg,
      e.bands.back().median_tilt_deg, e.mean_nees);
  ASSERT_GT(e.visible_frames, 30);
  EXPECT_GE(e.recall(), 0.85);
  EXPECT_EQ(e.false_positives, 0);
  // 640x360 environment cameras (the marker ~22 px) at 2.7-3.8 m.
  EXPECT_LT(e.bands.back().median_position_mm, 10.0);
  EXPECT_LT(e.bands.back().median_tilt_deg, 2.0);
  EXPECT_GT(e.mean_nees, 2.0);
  EXPECT_LT(e.mean_nees, 12.0);
  const BlobEvaluation be = evaluateBlobs(truth, blobs, 6.0, {0.0, 4.0, 100.0});
  ASSERT_EQ(be.bands.size(), 2u);
  std::printf(
      "small, first 4 s: blobs recall %d/%d (%d more hidden), %.2f false positives per frame, "
      "precision %.3f, centre error median %.2f px; within 4 m %d/%d\n",
      be.matched, be.expected, be.hidden, be.falsePositivesPerFrame(), be.precision(),
      be.median_error_px, be.bands[0].matched, be.bands[0].expected);
  // The housings the fisheye sees (the simulator says which the world hides).
  EXPECT_TRUE(be.knows_hidden);
  EXPECT_GE(be.recall(), 0.9);
  // The tie holes, grilles, wall joints and tray bays that the contrast test
  // alone keeps (22 per frame over the whole of `small`) fail the housing's
  // size and darkness tests.
  EXPECT_GE(be.precision(), 0.9);
  EXPECT_LT(be.median_error_px, 1.0);
  // Bands partition the housings in view.
  EXPECT_EQ(be.bands[0].expected + be.bands[1].expected, be.expected);
  EXPECT_EQ(be.bands[0].matched + be.bands[1].matched, be.matched);
}

// blobs.max_rate_hz: the 10 Hz fisheye at 5 Hz is searched every other
// frame, the same blobs in the frames searched, the same frames whatever
// the threads (the frames are chosen over the whole recording, not per job).
TEST_F(DetectDatasetTest, BlobsAtMostTheRate) {
  DetectOptions options;
  options.dataset = dir_ / "small.rawlog";
  options.config = defaultDetectConfig();
  options.markers = false;
  options.threads = 1;
  std::map<TimeNs, std::size_t> every;
  for (const Record& r : runDetection(options, ProgressReporter(), nullptr))
    every[std::get<BlobObservation>(r).t] = std::get<BlobObservation>(r).blobs.size();
  options.config.blobs.max_rate_hz = 5;
  for (const int threads : {1, 2}) {
    options.threads = threads;
    std::size_t searched = 0;
    for (const Record& r : runDetection(options, ProgressReporter(), nullptr)) {
      const auto& obs = std::get<BlobObservation>(r);
      ASSERT_TRUE(every.count(obs.t));
      EXPECT_EQ(obs.blobs.size(), every[obs.t]);
      ++searched;
    }
    EXPECT_GE(searched, every.size() / 2) << threads << " threads";
    EXPECT_LE(searched, (every.size() + 1) / 2) << threads << " threads";
  }
}

// The stored corners are the marker's true corners projected through the
// camera's model (sim ground truth), within the noise the detector stores.
TEST_F(DetectDatasetTest, StoresCornersWithinTheirNoiseOfTheTrueProjections) {
  DetectOptions options;
  options.dataset = dir_ / "small.rawlog";
  options.config = defaultDetectConfig();
  options.threads = 2;
  const std::vector<Record> records = runDetection(options, ProgressReporter(), nullptr);
  const GroundTruthView truth = loadGroundTruth(options.dataset);
  const double h = 0.5 * truth.manifest.marker.size_m;
  const Eigen::Vector3d corners_in_marker[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  int markers = 0;
  double sum_normalised = 0, sum_squared_px = 0, worst_px = 0;
  std::vector<double> sigmas;
  for (const Record& r : records) {
    const auto* m = std::get_if<MarkerObservation>(&r);
    if (!m) continue;
    ASSERT_EQ(m->corners_px.size(), 4u);
    ASSERT_GT(m->corner_sigma_px, 0.0);
    const auto camera_from_marker = truth.cameraFromMarker(m->camera, m->t);
    const CameraSensor* sensor = truth.manifest.findCamera(m->camera);
    ASSERT_TRUE(camera_from_marker && sensor && sensor->camera);
    for (int k = 0; k < 4; ++k) {
      const auto expected = sensor->camera->project(*camera_from_marker * corners_in_marker[k]);
      ASSERT_TRUE(expected);
      const Eigen::Vector2d error = m->corners_px[static_cast<size_t>(k)] - *expected;
      sum_squared_px += error.squaredNorm();
      sum_normalised += error.squaredNorm() / (m->corner_sigma_px * m->corner_sigma_px);
      worst_px = std::max(worst_px, error.norm());
    }
    sigmas.push_back(m->corner_sigma_px);
    ++markers;
  }
  ASSERT_GT(markers, 30);
  const double rms_px = std::sqrt(sum_squared_px / (8.0 * markers));
  const double mean_normalised = sum_normalised / (8.0 * markers);  // E = 1 if sigma is right
  std::printf(
      "small, first 4 s: %d markers, corner error rms %.3f px (worst %.3f px), median stored "
      "sigma %.3f px, mean (error/sigma)^2 per coordinate %.2f\n",
      markers, rms_px, worst_px, medianOf(sigmas), mean_normalised);
  // Measured: rms 0.036 px, worst 0.133 px, mean (error/sigma)^2 1.00.
  EXPECT_LT(rms_px, 0.1);
  EXPECT_LT(worst_px, 0.5);
  EXPECT_GT(mean_normalised, 0.5);
  EXPECT_LT(mean_normalised, 2.0);
}

TEST_F(DetectDatasetTest, WritesInPlaceReplacesOnRerunAndSkipsCorruptImages) {
  // A copy of the dataset with one frame of cam03 corrupted.
  const fs::path copy = dir_ / "copy.rawlog";
  {
    AugmentOptions duplicate;
    duplicate.input = dir_ / "small.rawlog";
    duplicate.output = copy;
    duplicate.link_images = false;
    augmentDataset(duplicate, {}, ProgressReporter());
  }
  fs::path corrupt;
  for (const auto& entry : fs::directory_iterator(dir_ / "copy_Images")) {
    if (entry.path().filename().string().rfind("cam03_", 0) == 0) {
      corrupt = entry.path();
      break;
    }
  }
  ASSERT_FALSE(corrupt.empty());
  std::ofstream(corrupt, std::ios::binary | std::ios::trunc) << "not a png";
  const std::size_t before = readAll(copy).size();

  DetectOptions options;
  options.dataset = copy;
  options.config = defaultDetectConfig();
  options.cameras = {"cam03", "fisheye"};
  std::vector<DatasetIssue> issues;
  options.on_issue = [&](const DatasetIssue& issue) { issues.push_back(issue); };
  const DetectSummary summary = detectDataset(options, ProgressReporter());
  std::int64_t skipped = 0, markers = 0;
  for (const CameraDetectSummary& c : summary.cameras) {
    skipped += c.skipped;
    if (!c.fisheye) markers += c.detections;
  }
  EXPECT_EQ(skipped, 1);
  bool named = false;
  for (const DatasetIssue& issue : issues) {
    named = named || issue.message.find(corrupt.filename().string()) != std::string::npos;
  }
  EXPECT_TRUE(named) << "the warning names the corrupt file";
  ASSERT_GT(markers, 10);
  const std::vector<Record> after = readAll(copy);
  EXPECT_EQ(after.size(), before + summary.written.added);
  // Only cam03's markers (cam04 was not asked for), with their corners and noise stored.
  for (const Record& r : after) {
    if (const auto* m = std::get_if<MarkerObservation>(&r)) {
      EXPECT_EQ(m->camera, "cam03");
      EXPECT_EQ(m->corners_px.size(), 4u);
      EXPECT_GT(m->corner_sigma_px, 0.0);
    }
  }
  // A second run replaces the detections instead of adding more.
  detectDataset(options, ProgressReporter());
  EXPECT_EQ(readAll(copy).size(), after.size());

  // An unknown camera is an error naming it; nothing is written.
  options.cameras = {"cam99"};
  try {
    detectDataset(options, ProgressReporter());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cam99"), std::string::npos) << e.what();
  }
  // Stopped: the dataset is unchanged.
  ProgressReporter stopped;
  stopped.requestStop();
  options.cameras = {"cam04"};
  EXPECT_THROW(detectDataset(options, stopped), StopRequested);
  EXPECT_EQ(readAll(copy).size(), after.size());
}

/// The markers of a coarse search (every frame examined when
/// `coarse_period_s` is 0), by (camera, time), and the frames it examined.
struct Searched {
  std::map<std::pair<std::string, TimeNs>, Eigen::Vector3d> markers;
  std::int64_t frames = 0, examined = 0, unchanged = 0, previews = 0;
  bool key_frames = false;
};
Searched searchMarkers(const fs::path& dataset, double coarse_period_s) {
  DetectOptions options;
  options.dataset = dataset;
  options.config = defaultDetectConfig();
  options.blobs = false;
  options.config.markers.coarse_period_s = coarse_period_s;
  DetectSummary summary;
  Searched searched;
  for (const Record& r : runDetection(options, ProgressReporter(), &summary)) {
    const auto& m = std::get<MarkerObservation>(r);
    searched.markers[{m.camera, m.t}] = m.camera_from_marker.translation;
  }
  for (const CameraDetectSummary& c : summary.cameras) {
    searched.frames += c.frames;
    searched.examined += c.examined;
    searched.unchanged += c.unchanged;
    searched.previews += c.previews;
    searched.key_frames = searched.key_frames || c.coarse_key_frames;
  }
  return searched;
}

/// Every marker that examining every frame finds is in `coarse` too, at the same pose.
void expectSameMarkers(const Searched& every, const Searched& coarse, const std::string& what) {
  std::printf(
      "%s: %zu markers examining every frame, %zu examining %lld of %lld (%lld unchanged, "
      "not searched; %lld previews)\n",
      what.c_str(), every.markers.size(), coarse.markers.size(),
      static_cast<long long>(coarse.examined), static_cast<long long>(coarse.frames),
      static_cast<long long>(coarse.unchanged), static_cast<long long>(coarse.previews));
  EXPECT_GT(every.markers.size(), 40u) << what;
  EXPECT_EQ(coarse.markers.size(), every.markers.size()) << what;
  for (const auto& [key, position] : every.markers) {
    const auto it = coarse.markers.find(key);
    ASSERT_NE(it, coarse.markers.end()) << what << ": " << key.first << " at " << key.second;
    EXPECT_LT((it->second - position).norm(), 1e-3) << what;
  }
  // Most frames of a full recording are not looked at, and of those looked
  // at, the views that had not changed are not searched (SceneChange).
  EXPECT_LT(coarse.examined, coarse.frames / 2) << what;
  EXPECT_GT(coarse.unchanged, 0) << what;
  EXPECT_EQ(every.unchanged, 0) << what;
  // A video's coarse key frames are searched as previews first.
  EXPECT_EQ(coarse.previews > 0, coarse.key_frames) << what;
}

/// Every marker that examining every frame finds, the coarse search finds
/// too, on a full recording (every frame of the drive, most without the
/// robot): `small`'s first 6 s, 6 cameras at 10 Hz, searched one frame in 5;
/// then its cameras as H.264 videos with a key frame a second, searched at
/// their key frames, made from the PNG files by ffmpeg and written by the
/// simulator.
TEST(CoarseSearch, FindsWhatEveryFrameFindsOnAFullRecording) {
  const fs::path dir = fs::temp_directory_path() / "lookboth_coarse_search_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ifstream in(shareDirectory() / "scenarios" / "small.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  const std::string radius = "store_radius_m: 2.0";
  ASSERT_NE(yaml.find(radius), std::string::npos);
  yaml.replace(yaml.find(radius), radius.size(), "store_radius_m: all");
  std::ofstream(dir / "full_recording.yaml") << yaml;
  sim::SimulateOptions simulate;
  simulate.scenario = (dir / "full_recording.yaml").string();
  simulate.out = dir / "site";
  simulate.kind = DatasetKind::kFolder;
  simulate.max_duration_s = 6.0;
  simulate.threads = 2;
  sim::simulate(simulate, ProgressReporter());

  expectSameMarkers(searchMarkers(simulate.out, 0), searchMarkers(simulate.out, 0.5), "PNG");
  const std::string script = std::string(LOOKBOTH_SHARE_DIR) + "/../../scripts/frames_to_video.py";
  for (int c = 0; c < 6; ++c) {
    const std::string command = "python3 '" + script + "' '" +
                                (simulate.out / "cameras" / ("cam0" + std::to_string(c))).string() +
                                "' --crf 18 --keyint 10";
    ASSERT_EQ(std::system(command.c_str()), 0) << command;
  }
  const Searched every = searchMarkers(simulate.out, 0);
  const Searched keys = searchMarkers(simulate.out, 0.5);
  EXPECT_TRUE(keys.key_frames);
  expectSameMarkers(every, keys, "H.264, a key frame a second");

  // The simulator writing each camera's video itself (cameras.video).
  const std::string cameras = "  store_radius_m: all\n";
  ASSERT_NE(yaml.find(cameras), std::string::npos);
  yaml.replace(yaml.find(cameras), cameras.size(),
               cameras + "  video: {crf: 18, key_frame_interval_s: 1}\n");
  std::ofstream(dir / "full_recording.yaml") << yaml;
  simulate.out = dir / "site_video";
  sim::simulate(simulate, ProgressReporter());
  EXPECT_TRUE(fs::exists(simulate.out / "cameras/cam00/video.mp4"));
  EXPECT_FALSE(fs::exists(simulate.out / "cameras/cam00/frames.csv"));
  EXPECT_FALSE(fs::exists(dir / "site_video-videos.partial"));  // the scratch folder is gone
  const Searched every_video = searchMarkers(simulate.out, 0);
  const Searched keys_video = searchMarkers(simulate.out, 0.5);
  EXPECT_TRUE(keys_video.key_frames);
  EXPECT_EQ(every_video.frames, every.frames);  // every frame of the drive, as from the PNG files
  expectSameMarkers(every_video, keys_video, "H.264 written by the simulator");
  std::size_t shared = 0;
  for (const auto& [key, position] : every.markers) shared += every_video.markers.count(key);
  EXPECT_GE(shared, every.markers.size() * 98 / 100);  // the same frames, compressed alike
  fs::remove_all(dir);
}

// default.yaml says what the compiled defaults say, every key of markers
// and blobs (a library user or a test that builds the options in code runs
// what `lookboth detect` runs).
TEST(DetectConfig, DefaultYamlSaysWhatTheCompiledDefaultsSay) {
  const DetectConfig loaded =
      loadDetectConfig(std::filesystem::path(LOOKBOTH_SHARE_DIR) / "config" / "default.yaml");
  const std::vector<std::string> found =
      optionDifferences(detectConfigYaml(loaded), detectConfigYaml(DetectConfig()), "detect");
  std::string listed;
  for (const std::string& line : found) listed += "\n  " + line;
  EXPECT_TRUE(found.empty()) << "default.yaml's value against the compiled one:" << listed;
  // A changed value is named with both.
  DetectConfig changed;
  changed.markers.max_speed_mps = 2.0;
  const std::vector<std::string> one =
      optionDifferences(detectConfigYaml(changed), detectConfigYaml(DetectConfig()), "detect");
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0], "detect.markers.max_speed_mps: 2 against 1.5");
}

// The configuration's layers: default.yaml, a user's file, then settings
// held in memory, each over the ones before.
TEST(DetectConfig, EveryLayerOverTheOnesBefore) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "lookboth_layers";
  std::filesystem::create_directories(dir);
  const std::filesystem::path user = dir / "user.yaml";
  std::ofstream(user) << "detect:\n  markers: {max_speed_mps: 0.9, track_window_s: 2.0}\n";
  const std::vector<ConfigLayer> layers =
      configurationLayers(user, "detect:\n  markers: {max_speed_mps: 0.7}\n");
  ASSERT_EQ(layers.size(), 3u);
  EXPECT_EQ(std::filesystem::path(layers[0].source).filename(), "default.yaml");
  EXPECT_EQ(layers[1].source, user.string());
  EXPECT_EQ(layers[2].source, kInMemorySettings);
  const DetectConfig config = detectConfigFrom(layers);
  EXPECT_DOUBLE_EQ(config.markers.max_speed_mps, 0.7);   // the settings
  EXPECT_DOUBLE_EQ(config.markers.track_window_s, 2.0);  // the user's file
  EXPECT_DOUBLE_EQ(config.blobs.min_contrast, DetectConfig().blobs.min_contrast);  // default.yaml
  try {
    detectConfigFrom(configurationLayers(std::nullopt, "detect:\n  blobs: {min_contrastt: 3}\n"));
    ADD_FAILURE() << "an unknown key in the settings was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(kInMemorySettings), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("min_contrastt"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

TEST(DetectConfig, ReadsTheDetectSectionStrictly) {
  const fs::path file = fs::temp_directory_path() / "lookboth_detect_config_test.yaml";
  std::ofstream(file) << "odometry: {x: 1}\n"
                         "detect:\n"
                         "  markers: {detect_scale: 1, corner_sigma_px: 0.2}\n"
                         "  blobs: {min_area_px: 7}\n";
  const DetectConfig config = loadDetectConfig(file);
  EXPECT_EQ(config.markers.detect_scale, 1);
  EXPECT_DOUBLE_EQ(config.markers.corner_sigma_px, 0.2);
  EXPECT_DOUBLE_EQ(config.blobs.min_area_px, 7);
  // Another stage's section is its owner's; a misspelled one is an error.
  std::ofstream(file) << "detekt:\n  blobs: {min_area_px: 7}\n";
  try {
    loadDetectConfig(file);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(":1: 'detekt': unknown key"), std::string::npos)
        << e.what();
  }
  std::ofstream(file) << "detect:\n  blobs:\n    min_aera_px: 7\n";
  try {
    loadDetectConfig(file);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("min_aera_px"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(":3"), std::string::npos) << e.what();
  }
  fs::remove(file);
  // The shipped default is valid.
  EXPECT_EQ(defaultDetectConfig().check(), "");
}

// The user's --config layers over share/lookboth/config/default.yaml as the
// register section does: keys it leaves out keep default.yaml's value, not
// the compiled one (here a share folder whose default.yaml differs from both).
TEST(DetectConfig, TheUsersFileLayersOverDefaultYaml) {
  const fs::path share = fs::temp_directory_path() / "lookboth_detect_layer_test";
  fs::create_directories(share / "config");
  fs::create_directories(share / "cameras");  // what marks a share folder
  std::ofstream(share / "config" / "default.yaml")
      << "detect:\n  markers: {max_speed_mps: 0.7, corner_sigma_px: 0.3}\n";
  const fs::path user = share / "user.yaml";
  std::ofstream(user) << "detect:\n  markers: {corner_sigma_px: 0.2}\n";
  DetectConfig plain, layered;
  {
    const ScopedEnvironment share_dir("LOOKBOTH_SHARE_DIR", share.string());
    plain = detectConfigFor(std::nullopt);
    layered = detectConfigFor(user);
  }
  fs::remove_all(share);
  EXPECT_DOUBLE_EQ(plain.markers.max_speed_mps, 0.7);
  EXPECT_DOUBLE_EQ(plain.markers.corner_sigma_px, 0.3);
  EXPECT_DOUBLE_EQ(layered.markers.max_speed_mps, 0.7);    // from default.yaml
  EXPECT_DOUBLE_EQ(layered.markers.corner_sigma_px, 0.2);  // the user's
}

// The pass statistic of evaluateMarkers against the simulator's model of
// errors a pass shares (noise.marker_pass_share): `paper`'s detections (43
// cameras, one pass each) with independent errors score no share, with a
// share of 0.3 about that.
std::vector<MarkerObservation> pathDetections(const fs::path& dir, double share) {
  std::string yaml = builtinScenarioText("paper");
  const std::string key = "noise: {";
  const auto at = yaml.find(key);
  if (at == std::string::npos) throw std::runtime_error("paper.yaml: no noise section");
  yaml.insert(at + key.size(), "marker_pass_share: " + std::to_string(share) + ", ");
  sim::SimulateOptions options;
  options.scenario = writeScenario(yaml, dir / ("paper_share_" + std::to_string(share) + ".yaml"));
  options.out = dir / ("paper_" + std::to_string(share) + ".rawlog");
  options.detections_only = true;
  options.max_duration_s = 60;
  sim::simulate(options, ProgressReporter());
  std::vector<MarkerObservation> markers;
  auto reader = DatasetReader::open(options.out);
  while (auto r = reader->next()) {
    if (const auto* m = std::get_if<MarkerObservation>(&*r)) markers.push_back(*m);
  }
  return markers;
}

TEST(PassStatistics, MeasureTheShareOfTheErrorThatAPassShares) {
  const fs::path dir = fs::temp_directory_path() / "lookboth_pass_statistics_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const double share : {0.0, 0.3}) {
    const auto markers = pathDetections(dir, share);
    const GroundTruthView truth =
        loadGroundTruth(dir / ("paper_" + std::to_string(share) + ".rawlog"));
    const MarkerEvaluation e = evaluateMarkers(truth, markers, {}, {0.0, 100.0});
    std::printf("share %.2f: %d passes of %.1f detections, pass NEES %.2f, measured share %.3f\n",
                share, e.passes, e.mean_pass_detections, e.mean_pass_nees, e.pass_error_share);
    ASSERT_GE(e.passes, 10);
    if (share == 0) {
      EXPECT_LT(e.pass_error_share, 0.03);
      EXPECT_GT(e.mean_pass_nees, 4.0);
      EXPECT_LT(e.mean_pass_nees, 8.0);
    } else {
      EXPECT_GT(e.pass_error_share, 0.6 * share);
      EXPECT_LT(e.pass_error_share, 1.5 * share);
    }
  }
  fs::remove_all(dir);
}

// A housing the ground truth says is hidden from the fisheye is neither a
// miss nor, when a blob lies on it, a false positive; recall is over the
// others and, apart, with the hidden ones counted as misses.
TEST(BlobEvaluation, HousingsHiddenFromTheFisheyeAreScoredApart) {
  GroundTruthView truth;
  const Camera up(PinholeModel{}, 640, 480, {300, 300, 320, 240});  // looks along +z
  truth.manifest.cameras.push_back({"fisheye", SensorRole::kFisheye, up});
  truth.manifest.cameras.push_back({"a", SensorRole::kEnvCamera, up});
  truth.manifest.cameras.push_back({"b", SensorRole::kEnvCamera, up});
  truth.manifest.ground_truth.world_from_camera["a"] =
      Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 3));
  truth.manifest.ground_truth.world_from_camera["b"] =
      Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5, 0, 3));
  truth.manifest.ground_truth.hidden_from_fisheye["b"] = {{100, 200}};
  truth.world_from_fisheye.append(0, Rigid3d());
  truth.world_from_fisheye.append(1000, Rigid3d());
  const Blob on_a{320, 240, 10, 1}, on_b{370, 240, 10, 1}, elsewhere{100, 100, 10, 1};
  std::vector<BlobObservation> observations(2);
  observations[0].t = 100;  // b hidden, yet a blob on it
  observations[0].camera = "fisheye";
  observations[0].blobs = {on_a, on_b};
  observations[1].t = 300;  // b in sight and missed; a blob on nothing
  observations[1].camera = "fisheye";
  observations[1].blobs = {on_a, elsewhere};
  const BlobEvaluation e = evaluateBlobs(truth, observations);
  EXPECT_TRUE(e.knows_hidden);
  EXPECT_EQ(e.frames, 2);
  EXPECT_EQ(e.expected, 3);
  EXPECT_EQ(e.matched, 2);
  EXPECT_EQ(e.hidden, 1);
  EXPECT_EQ(e.hidden_matched, 1);
  EXPECT_EQ(e.false_positives, 1);
  EXPECT_DOUBLE_EQ(e.recall(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(e.recallOfAllInImage(), 3.0 / 4.0);

  truth.manifest.ground_truth.hidden_from_fisheye.clear();  // a dataset that does not say
  const BlobEvaluation blind = evaluateBlobs(truth, observations);
  EXPECT_FALSE(blind.knows_hidden);
  EXPECT_EQ(blind.expected, 4);
  EXPECT_EQ(blind.matched, 3);
  EXPECT_EQ(blind.false_positives, 1);
}

}  // namespace
}  // namespace lookboth
