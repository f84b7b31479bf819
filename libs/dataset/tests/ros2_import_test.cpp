// ROS 2 bag -> dataset: the fixtures of tests/data/ros2 (written by the
// npm MCAP and CDR libraries, not by lookboth) imported through importRosbag
// in every storage form, read back and compared with the writer's values in
// expected.json; and the errors a technician meets first.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "lookboth/core/error.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/dataset/rosbag_import.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

const fs::path kData = fs::path(LOOKBOTH_TEST_DATA_DIR) / "ros2";

const json& expected() {
  static const json kExpected = json::parse(std::ifstream(kData / "expected.json"));
  return kExpected;
}

std::vector<std::string> storageForms() {
  return {
      "sample_uncompressed.mcap", "sample_lz4.mcap",    "sample_zstd.mcap", "sample_unchunked.mcap",
      "sample_nosummary.mcap",    "sample_mcap_folder", "sample_db3"};
}

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TimeNs stampOf(const json& header) {
  return header["stamp"]["sec"].get<TimeNs>() * 1'000'000'000 +
         header["stamp"]["nanosec"].get<TimeNs>();
}

RosbagImportOptions sampleOptions() {
  RosbagImportOptions options;
  options.topics = {parseTopicMapping("/fisheye/image_raw=fisheye:fisheye"),
                    parseTopicMapping("/env_cam/image/compressed=env_cam:env_camera"),
                    parseTopicMapping("/odom=odometry:odometry"),
                    parseTopicMapping("/ground_truth/pose=ground_truth:ground_truth"),
                    parseTopicMapping("/initialpose=initial:odometry"),
                    parseTopicMapping("/tf=tf_base:odometry:child=base_link:parent=odom")};
  options.marker = MarkerSpec{"DICT_4X4_50", 0, 0.2};
  options.on_warning = [](const std::string&) {};
  return options;
}

class Ros2Import : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / "lookboth_ros2_import";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  /// Imports `form` to a rawlog and returns its records, one line each.
  std::vector<Record> imported(const std::string& form, const std::string& out_name) {
    const fs::path out = dir_ / out_name / "sample.rawlog";
    fs::create_directories(out.parent_path());
    importRosbag(kData / form, out, DatasetKind::kRawlog, sampleOptions(), {}, {});
    std::unique_ptr<DatasetReader> reader = DatasetReader::open(out);
    std::vector<Record> records;
    while (std::optional<Record> r = reader->next()) records.push_back(std::move(*r));
    return records;
  }

  fs::path dir_;
};

/// The encoded bytes of a frame read back: in memory or in its file.
std::vector<std::uint8_t> encodedBytes(const ImageFrame& frame) {
  if (frame.encoded) return *frame.encoded;
  std::ifstream in(frame.image_file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// A pose record against a geometry_msgs/Pose object of expected.json.
void expectPose(const PoseSample& sample, const json& pose) {
  const json& p = pose["position"];
  const json& o = pose["orientation"];
  const Eigen::Quaterniond q(o["w"].get<double>(), o["x"].get<double>(), o["y"].get<double>(),
                             o["z"].get<double>());
  EXPECT_NEAR(sample.world_from_body.translation.x(), p["x"].get<double>(), 1e-12);
  EXPECT_NEAR(sample.world_from_body.translation.y(), p["y"].get<double>(), 1e-12);
  EXPECT_NEAR(sample.world_from_body.translation.z(), p["z"].get<double>(), 1e-12);
  EXPECT_NEAR(sample.world_from_body.rotation.angularDistance(q.normalized()), 0.0, 1e-9);
}

/// What each mapped message of expected.json becomes, in the bag's order.
void expectRecords(const std::vector<Record>& records) {
  std::size_t at = 0;
  auto nextRecord = [&]() -> const Record& {
    EXPECT_LT(at, records.size());
    return records.at(at++);
  };
  for (const json& m : expected()["messages"]) {
    const std::string topic = m["topic"];
    const json& msg = m["message"];
    if (topic == "/fisheye/image_raw" || topic == "/env_cam/image/compressed") {
      const auto& frame = std::get<ImageFrame>(nextRecord());
      EXPECT_EQ(frame.t, stampOf(msg["header"]));
      EXPECT_EQ(frame.sensor, topic == "/fisheye/image_raw" ? "fisheye" : "env_cam");
      const std::vector<std::uint8_t> encoded = encodedBytes(frame);
      const cv::Mat image = cv::imdecode(encoded, cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(image.empty()) << topic;
      EXPECT_EQ(image.cols, 8);
      EXPECT_EQ(image.rows, 6);
      if (topic == "/fisheye/image_raw") {  // re-encoded losslessly
        const std::vector<std::uint8_t> data = msg["data"];
        EXPECT_TRUE(std::equal(data.begin(), data.end(), image.ptr<std::uint8_t>()));
      } else {  // the bytes as recorded
        EXPECT_EQ(encoded, msg["data"].get<std::vector<std::uint8_t>>());
      }
    } else if (topic == "/odom" || topic == "/ground_truth/pose" || topic == "/initialpose") {
      const auto& sample = std::get<PoseSample>(nextRecord());
      EXPECT_EQ(sample.t, stampOf(msg["header"]));
      expectPose(sample, topic == "/ground_truth/pose" ? msg["pose"] : msg["pose"]["pose"]);
    } else if (topic == "/tf") {
      for (const json& transform : msg["transforms"]) {
        if (transform["child_frame_id"] != "base_link") continue;
        const auto& sample = std::get<PoseSample>(nextRecord());
        EXPECT_EQ(sample.label, "tf_base");
        EXPECT_EQ(sample.t, stampOf(transform["header"]));
        json pose;
        pose["position"] = transform["transform"]["translation"];
        pose["orientation"] = transform["transform"]["rotation"];
        expectPose(sample, pose);
      }
    }
  }
  EXPECT_EQ(at, records.size());
}

TEST_F(Ros2Import, EveryStorageFormGivesTheWritersMessages) {
  for (const std::string& form : storageForms()) {
    SCOPED_TRACE(form);
    const std::vector<Record> records = imported(form, form);
    EXPECT_EQ(records.size(), 3u + 2u + 5u + 3u + 2u + 2u);
    expectRecords(records);
  }
}

TEST_F(Ros2Import, EveryStorageFormWritesTheSameDataset) {
  auto bytes = [](const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  imported("sample_uncompressed.mcap", "reference");
  const std::string reference = bytes(dir_ / "reference" / "sample.rawlog");
  ASSERT_FALSE(reference.empty());
  for (const std::string& form : storageForms()) {
    imported(form, form);
    EXPECT_EQ(bytes(dir_ / form / "sample.rawlog"), reference) << form;
  }
}

TEST_F(Ros2Import, ReceiveTimesAreTheLogTimes) {
  RosbagImportOptions options = sampleOptions();
  options.use_header_stamp = false;
  options.topics = {parseTopicMapping("/odom=odometry:odometry")};
  const fs::path out = dir_ / "receive.rawlog";
  importRosbag(kData / "sample_db3", out, DatasetKind::kRawlog, options, {}, {});
  std::unique_ptr<DatasetReader> reader = DatasetReader::open(out);
  std::vector<TimeNs> times;
  while (std::optional<Record> r = reader->next()) times.push_back(std::get<PoseSample>(*r).t);
  std::vector<TimeNs> log_times;
  for (const json& m : expected()["messages"]) {
    if (m["topic"] == "/odom") log_times.push_back(std::stoll(m["log_time"].get<std::string>()));
  }
  EXPECT_EQ(times, log_times);
}

TEST_F(Ros2Import, ATransformTopicNeedsItsFrame) {
  RosbagImportOptions options = sampleOptions();
  options.topics = {parseTopicMapping("/tf=tf_base:odometry")};
  const std::string why = errorOf([&] {
    importRosbag(kData / "sample_lz4.mcap", dir_ / "x.rawlog", DatasetKind::kRawlog, options, {},
                 {});
  });
  EXPECT_NE(why.find("sample_lz4.mcap"), std::string::npos) << why;
  EXPECT_NE(why.find("/tf (tf2_msgs/msg/TFMessage)"), std::string::npos) << why;
  EXPECT_NE(why.find("child=<frame>"), std::string::npos) << why;
  EXPECT_FALSE(fs::exists(dir_ / "x.rawlog"));
}

/// A pose of expected.json as an isometry (Eigen's, not the importer's Rigid3).
Eigen::Isometry3d isometryOf(const json& pose) {
  const json& p = pose["position"];
  const json& o = pose["orientation"];
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = Eigen::Quaterniond(o["w"].get<double>(), o["x"].get<double>(),
                                    o["y"].get<double>(), o["z"].get<double>())
                     .normalized()
                     .toRotationMatrix();
  out.translation() =
      Eigen::Vector3d(p["x"].get<double>(), p["y"].get<double>(), p["z"].get<double>());
  return out;
}

/// The mount the fixture's /tf_static describes (write_mcap.mjs): base_link
/// -> mast (0.1, 0.02, 0.3; yaw 0.25), mast -> fisheye_link (0, 0.02, 0.05; yaw 0.5).
Eigen::Isometry3d baseFromFisheye() {
  auto mount = [](double x, double z, double yaw) {
    Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
    m.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    m.translation() = Eigen::Vector3d(x, 0.02, z);
    return m;
  };
  return mount(0.1, 0.3, 0.25) * mount(0, 0.05, 0.5);
}

TEST_F(Ros2Import, TrajectoriesAreCarriedToTheBodyFrameThroughTfStatic) {
  RosbagImportOptions options = sampleOptions();
  options.topics = {parseTopicMapping("/odom=odometry:odometry:body=fisheye_link"),
                    parseTopicMapping("/tf=tf_fish:odometry:child=base_link:body=fisheye_link")};
  const fs::path out = dir_ / "body.rawlog";
  importRosbag(kData / "sample_tf_static.mcap", out, DatasetKind::kRawlog, options, {}, {});
  std::vector<PoseSample> odometry, tf;
  std::unique_ptr<DatasetReader> reader = DatasetReader::open(out);
  while (std::optional<Record> r = reader->next()) {
    const auto& pose = std::get<PoseSample>(*r);
    (pose.label == "odometry" ? odometry : tf).push_back(pose);
  }
  std::vector<Eigen::Isometry3d> odom_expected, tf_expected;
  for (const json& m : expected()["messages"]) {
    if (m["topic"] == "/odom")
      odom_expected.push_back(isometryOf(m["message"]["pose"]["pose"]) * baseFromFisheye());
    if (m["topic"] != "/tf") continue;
    for (const json& t : m["message"]["transforms"]) {
      if (t["child_frame_id"] != "base_link") continue;
      json pose;
      pose["position"] = t["transform"]["translation"];
      pose["orientation"] = t["transform"]["rotation"];
      tf_expected.push_back(isometryOf(pose) * baseFromFisheye());
    }
  }
  ASSERT_EQ(odometry.size(), odom_expected.size());
  ASSERT_EQ(tf.size(), tf_expected.size());
  ASSERT_FALSE(tf.empty());
  auto expectSame = [](const PoseSample& sample, const Eigen::Isometry3d& truth) {
    EXPECT_LT((sample.world_from_body.translation - truth.translation()).norm(), 1e-12);
    EXPECT_LT(sample.world_from_body.rotation.angularDistance(Eigen::Quaterniond(truth.linear())),
              1e-9);
  };
  for (size_t i = 0; i < odometry.size(); ++i) expectSame(odometry[i], odom_expected[i]);
  for (size_t i = 0; i < tf.size(); ++i) expectSame(tf[i], tf_expected[i]);
}

TEST_F(Ros2Import, ABodyFrameNeedsItsMountsInTfStatic) {
  RosbagImportOptions options = sampleOptions();
  options.topics = {parseTopicMapping("/odom=odometry:odometry:body=camera_link")};
  std::string why = errorOf([&] {
    importRosbag(kData / "sample_tf_static.mcap", dir_ / "x.rawlog", DatasetKind::kRawlog, options,
                 {}, {});
  });
  EXPECT_NE(why.find("topic /odom, message 1: no static transforms connect 'base_link'"),
            std::string::npos)
      << why;
  EXPECT_NE(why.find("base_link -> lidar, base_link -> mast, mast -> fisheye_link"),
            std::string::npos)
      << why;
  EXPECT_FALSE(fs::exists(dir_ / "x.rawlog"));
  why = errorOf([&] {
    importRosbag(kData / "sample_lz4.mcap", dir_ / "x.rawlog", DatasetKind::kRawlog, options, {},
                 {});
  });
  EXPECT_NE(why.find("needs the robot's mounts from /tf_static, which the bag does not have"),
            std::string::npos)
      << why;
  options.topics = {parseTopicMapping("/ground_truth/pose=ground_truth:ground_truth:body=x")};
  why = errorOf([&] {
    importRosbag(kData / "sample_lz4.mcap", dir_ / "x.rawlog", DatasetKind::kRawlog, options, {},
                 {});
  });
  EXPECT_NE(why.find("does not name the frame of its poses"), std::string::npos) << why;
}

TEST_F(Ros2Import, NamesTheTopicsOfTheBagWhenOneIsMissing) {
  RosbagImportOptions options = sampleOptions();
  options.topics.push_back(parseTopicMapping("/cam07/image=cam07:env_camera"));
  const std::string why = errorOf([&] {
    importRosbag(kData / "sample_db3", dir_ / "x.rawlog", DatasetKind::kRawlog, options, {}, {});
  });
  EXPECT_NE(why.find("topic /cam07/image is not in the bag"), std::string::npos) << why;
  EXPECT_NE(why.find("/odom (nav_msgs/msg/Odometry)"), std::string::npos) << why;
}

TEST_F(Ros2Import, ACameraInfoWithBinningIsRefusedByTopic) {
  RosbagImportOptions options = sampleOptions();
  options.topics.push_back(parseTopicMapping("/fisheye/camera_info=fisheye:fisheye"));
  const std::string why = errorOf([&] {
    importRosbag(kData / "sample_zstd.mcap", dir_ / "x.rawlog", DatasetKind::kRawlog, options, {},
                 {});
  });
  EXPECT_NE(why.find("topic /fisheye/camera_info, message 1"), std::string::npos) << why;
  EXPECT_NE(why.find("binning"), std::string::npos) << why;
}

TEST_F(Ros2Import, ATruncatedBagIsAnErrorAndLeavesNothing) {
  const fs::path cut = dir_ / "cut.mcap";
  fs::copy_file(kData / "sample_lz4.mcap", cut);
  // Inside the data section (its chunks end at about half the file; the
  // summary after them is not needed to read the messages).
  fs::resize_file(cut, fs::file_size(cut) / 4);
  const fs::path out = dir_ / "out.rawlog";
  const std::string why =
      errorOf([&] { importRosbag(cut, out, DatasetKind::kRawlog, sampleOptions(), {}, {}); });
  EXPECT_NE(why.find("cut.mcap"), std::string::npos) << why;
  EXPECT_NE(why.find("truncated at byte"), std::string::npos) << why;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir_ / "out.yaml"));
}

// Cut after its last message (half of sample_lz4.mcap lies in its summary,
// past the Data End record): every message is read, and a warning says the
// recording was cut.
TEST_F(Ros2Import, ABagCutAfterItsMessagesIsReadWithAWarning) {
  const fs::path cut = dir_ / "cut.mcap";
  fs::copy_file(kData / "sample_lz4.mcap", cut);
  fs::resize_file(cut, fs::file_size(cut) / 2);
  RosbagImportOptions options = sampleOptions();
  std::vector<std::string> warnings;
  options.on_warning = [&](const std::string& w) { warnings.push_back(w); };
  const RosbagImportStats stats =
      importRosbag(cut, dir_ / "cut.rawlog", DatasetKind::kRawlog, options, {}, {});
  EXPECT_EQ(stats.records, 17);
  // (The other warnings: the two cameras have no calibration in this mapping.)
  const auto cut_warnings = std::count_if(warnings.begin(), warnings.end(), [](const auto& w) {
    return w.find("cut.mcap ends without the MCAP footer") != std::string::npos;
  });
  EXPECT_EQ(cut_warnings, 1);
}

TEST(Ros2TopicMapping, ParsesFramesAndRefusesThemOnCameras) {
  const RosTopicMapping m = parseTopicMapping("/tf=gt:ground_truth:child=base_link:parent=map");
  EXPECT_EQ(m.child_frame, "base_link");
  EXPECT_EQ(m.parent_frame, "map");
  EXPECT_NE(errorOf([] {
              parseTopicMapping("/cam/image=cam:env_camera:child=x");
            }).find("is for trajectories"),
            std::string::npos);
  EXPECT_NE(errorOf([] {
              parseTopicMapping("/tf=gt:ground_truth:frame=x");
            }).find("unknown flag 'frame=x'"),
            std::string::npos);
}

}  // namespace
}  // namespace lookboth
