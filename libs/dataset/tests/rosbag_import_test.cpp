// ROS 1 bag -> dataset: writes small bags with the rosbag C++ API, imports
// them into folder and rawlog datasets and reads them back.
#include "lookboth/dataset/rosbag_import.h"

#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "lookboth/core/error.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

constexpr std::uint32_t kSec0 = 1'700'000'000;

ros::Time rosTime(std::uint32_t sec, std::uint32_t nsec) { return ros::Time(sec, nsec); }
TimeNs ns(const ros::Time& t) { return static_cast<TimeNs>(t.sec) * 1'000'000'000 + t.nsec; }

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

/// Everything written into the sample bag, to compare with what comes back.
struct SampleBag {
  struct Frame {
    ros::Time stamp;
    ros::Time received;
    cv::Mat image;
  };
  struct Pose {
    ros::Time stamp;
    ros::Time received;
    Rigid3d pose;
  };
  std::vector<Frame> fisheye;  // 64x48 bgr8 raw images
  std::vector<Frame> cam03;    // 40x30 mono8, PNG-compressed
  std::vector<Frame> cam04;    // 36x20 bgr8, JPEG-compressed (no camera info)
  std::vector<Pose> odometry;
  std::vector<Pose> ground_truth;
};

sensor_msgs::CameraInfo fisheyeInfo(const ros::Time& stamp) {
  sensor_msgs::CameraInfo info;
  info.header.stamp = stamp;
  info.header.frame_id = "fisheye";
  info.width = 64;
  info.height = 48;
  info.distortion_model = "equidistant";
  info.D = {0.01, -0.002, 0.0005, -0.0001};
  info.K = {30.0, 0.0, 31.5, 0.0, 30.5, 23.5, 0.0, 0.0, 1.0};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {30.0, 0.0, 31.5, 0.0, 0.0, 30.5, 23.5, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

sensor_msgs::CameraInfo cam03Info(const ros::Time& stamp) {
  sensor_msgs::CameraInfo info;
  info.header.stamp = stamp;
  info.width = 40;
  info.height = 30;
  info.distortion_model = "plumb_bob";
  info.D = {-0.1, 0.02, 0.001, -0.002, 0.003};
  info.K = {50.0, 0.0, 19.5, 0.0, 51.0, 14.5, 0.0, 0.0, 1.0};
  return info;
}

Rigid3d samplePose(int i, double offset) {
  const Eigen::Quaterniond q = Eigen::Quaterniond(
      Eigen::AngleAxisd(0.1 * i + offset, Eigen::Vector3d(0.2, 0.3, 1.0).normalized()));
  return Rigid3d(q, Eigen::Vector3d(0.5 * i + offset, -0.25 * i, 0.01 * i));
}

geometry_msgs::Pose toRos(const Rigid3d& pose) {
  geometry_msgs::Pose p;
  p.position.x = pose.translation.x();
  p.position.y = pose.translation.y();
  p.position.z = pose.translation.z();
  p.orientation.w = pose.rotation.w();
  p.orientation.x = pose.rotation.x();
  p.orientation.y = pose.rotation.y();
  p.orientation.z = pose.rotation.z();
  return p;
}

struct BagVariant {
  bool change_fisheye_info = false;  // the 4th fisheye CameraInfo differs
  rosbag::compression::CompressionType compression = rosbag::compression::Uncompressed;
  bool small = false;  // 2 + 2 + 1 frames and 3 + 3 poses (still several chunks)
};

SampleBag writeSampleBag(const fs::path& path, const BagVariant& variant = {}) {
  SampleBag sample;
  rosbag::Bag bag(path.string(), rosbag::bagmode::Write);
  bag.setCompression(variant.compression);
  bag.setChunkThreshold(4096);  // several chunks
  cv::RNG rng(42);
  for (int i = 0; i < (variant.small ? 2 : 5); ++i) {
    SampleBag::Frame frame;
    frame.stamp = rosTime(kSec0, 100'000'000 * i + 123);  // not a multiple of 100 ns
    frame.received = rosTime(kSec0, 100'000'000 * i + 5'000'000);
    frame.image = cv::Mat(48, 64, CV_8UC3);
    rng.fill(frame.image, cv::RNG::UNIFORM, 0, 256);
    sensor_msgs::Image image;
    image.header.stamp = frame.stamp;
    image.header.frame_id = "fisheye";
    image.width = 64;
    image.height = 48;
    image.encoding = "bgr8";
    image.step = 64 * 3;
    image.data.assign(frame.image.data, frame.image.data + frame.image.total() * 3);
    bag.write("/fisheye/image_raw", frame.received, image);
    sensor_msgs::CameraInfo info = fisheyeInfo(frame.stamp);
    if (variant.change_fisheye_info && i == 3) info.K[0] = 31.0;
    bag.write("/fisheye/camera_info", frame.received, info);
    sample.fisheye.push_back(frame);
  }
  for (int i = 0; i < (variant.small ? 2 : 4); ++i) {
    SampleBag::Frame frame;
    frame.stamp = rosTime(kSec0, 120'000'000 * i + 7);
    frame.received = rosTime(kSec0, 120'000'000 * i + 9'000'000);
    frame.image = cv::Mat(30, 40, CV_8UC1);
    rng.fill(frame.image, cv::RNG::UNIFORM, 0, 256);
    sensor_msgs::CompressedImage image;
    image.header.stamp = frame.stamp;
    image.format = "mono8; png compressed ";
    std::vector<uchar> png;
    cv::imencode(".png", frame.image, png);
    image.data.assign(png.begin(), png.end());
    if (i == 0) bag.write("/cam03/camera_info", frame.received, cam03Info(frame.stamp));
    bag.write("/cam03/image/compressed", frame.received, image);
    sample.cam03.push_back(frame);
  }
  for (int i = 0; i < (variant.small ? 1 : 3); ++i) {
    SampleBag::Frame frame;
    frame.stamp = rosTime(kSec0 + 1, 1000 * i);
    frame.received = frame.stamp;
    frame.image = cv::Mat(20, 36, CV_8UC3, cv::Scalar(10 * i, 100, 200));
    sensor_msgs::CompressedImage image;
    image.header.stamp = frame.stamp;
    image.format = "jpeg";
    std::vector<uchar> jpeg;
    cv::imencode(".jpg", frame.image, jpeg);
    image.data.assign(jpeg.begin(), jpeg.end());
    bag.write("/cam04/image/compressed", frame.received, image);
    sample.cam04.push_back(frame);
  }
  for (int i = 0; i < (variant.small ? 3 : 10); ++i) {
    SampleBag::Pose pose;
    pose.stamp = rosTime(kSec0, 50'000'000 * i + 999);
    pose.received = rosTime(kSec0, 50'000'000 * i + 2'000'000);
    pose.pose = samplePose(i, 0.0);
    nav_msgs::Odometry odometry;
    odometry.header.stamp = pose.stamp;
    odometry.header.frame_id = "odom";
    odometry.child_frame_id = "base_link";
    odometry.pose.pose = toRos(pose.pose);
    bag.write("/odom", pose.received, odometry);
    sample.odometry.push_back(pose);

    SampleBag::Pose truth;
    truth.stamp = rosTime(kSec0, 50'000'000 * i + 31);
    truth.received = rosTime(kSec0, 50'000'000 * i + 3'000'000);
    truth.pose = samplePose(i, 0.05);
    geometry_msgs::PoseStamped stamped;
    stamped.header.stamp = truth.stamp;
    stamped.pose = toRos(truth.pose);
    bag.write("/ground_truth/pose", truth.received, stamped);
    sample.ground_truth.push_back(truth);
  }
  std_msgs::String chatter;
  chatter.data = "hello";
  bag.write("/chatter", rosTime(kSec0, 1), chatter);
  bag.close();
  return sample;
}

RosbagImportOptions sampleOptions() {
  RosbagImportOptions options;
  options.topics = {
      {"/fisheye/image_raw", "fisheye", "fisheye", true, "", "", ""},
      {"/fisheye/camera_info", "fisheye", "fisheye", true, "", "", ""},
      {"/cam03/image/compressed", "cam03", "env_camera", true, "", "", ""},
      {"/cam03/camera_info", "cam03", "env_camera", true, "", "", ""},
      {"/odom", "odometry", "odometry", false, "", "", ""},
      {"/ground_truth/pose", "", "ground_truth", true, "", "", ""},
  };
  options.marker = {"DICT_5X5_100", 17, 0.15};
  options.on_warning = [](const std::string&) {};
  return options;
}

cv::Mat decode(const ImageFrame& frame) {
  if (frame.encoded) return cv::imdecode(*frame.encoded, cv::IMREAD_UNCHANGED);
  return cv::imread(frame.image_file.string(), cv::IMREAD_UNCHANGED);
}

bool samePixels(const cv::Mat& a, const cv::Mat& b) {
  if (a.size() != b.size() || a.type() != b.type()) return false;
  return cv::norm(a, b, cv::NORM_INF) == 0.0;
}

struct ReadBack {
  Manifest manifest;
  std::map<std::string, std::vector<ImageFrame>> frames;
  std::map<std::string, std::vector<PoseSample>> poses;
  std::vector<DatasetIssue> issues;
  size_t records = 0;
};

ReadBack readBack(const fs::path& path) {
  ReadBack out;
  auto reader = DatasetReader::open(path);
  out.manifest = reader->manifest();
  while (auto record = reader->next()) {
    ++out.records;
    if (const auto* frame = std::get_if<ImageFrame>(&*record))
      out.frames[frame->sensor].push_back(*frame);
    if (const auto* pose = std::get_if<PoseSample>(&*record))
      out.poses[pose->label].push_back(*pose);
  }
  out.issues = reader->issues();
  return out;
}

class RosbagImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("lookboth_rosbag_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
};

/// Checks the whole import; `exact_time(t)` is how a time comes back.
void checkImported(const SampleBag& sample, const ReadBack& back,
                   const std::function<TimeNs(TimeNs)>& exact_time) {
  // Manifest.
  EXPECT_EQ(back.manifest.marker.dictionary, "DICT_5X5_100");
  EXPECT_EQ(back.manifest.marker.id, 17);
  EXPECT_DOUBLE_EQ(back.manifest.marker.size_m, 0.15);
  ASSERT_EQ(back.manifest.cameras.size(), 2u);
  const CameraSensor& fisheye = back.manifest.cameras[0];
  EXPECT_EQ(fisheye.label, "fisheye");
  EXPECT_EQ(fisheye.role, SensorRole::kFisheye);
  ASSERT_TRUE(fisheye.camera.has_value());
  EXPECT_EQ(fisheye.camera->modelName(), "kannala_brandt");
  EXPECT_EQ(fisheye.camera->width(), 64);
  EXPECT_EQ(fisheye.camera->height(), 48);
  EXPECT_EQ(fisheye.camera->params(),
            (std::vector<double>{30.0, 30.5, 31.5, 23.5, 0.01, -0.002, 0.0005, -0.0001}));
  const CameraSensor& cam03 = back.manifest.cameras[1];
  EXPECT_EQ(cam03.label, "cam03");
  EXPECT_EQ(cam03.role, SensorRole::kEnvCamera);
  ASSERT_TRUE(cam03.camera.has_value());
  EXPECT_EQ(cam03.camera->modelName(), "radtan");
  EXPECT_EQ(cam03.camera->width(), 40);
  EXPECT_EQ(cam03.camera->params(),
            (std::vector<double>{50.0, 51.0, 19.5, 14.5, -0.1, 0.02, 0.001, -0.002, 0.003}));
  ASSERT_EQ(back.manifest.trajectories.size(), 2u);
  const TrajectoryInfo* odometry = back.manifest.findTrajectory("odometry");
  ASSERT_NE(odometry, nullptr);
  EXPECT_FALSE(odometry->metric);
  const TrajectoryInfo* truth = back.manifest.findTrajectory("ground_truth");
  ASSERT_NE(truth, nullptr);
  EXPECT_TRUE(truth->metric);

  // Records.
  EXPECT_TRUE(back.issues.empty())
      << back.issues.front().where << ": " << back.issues.front().message;
  EXPECT_EQ(back.records, 5u + 4u + 10u + 10u);
  ASSERT_EQ(back.frames.count("fisheye"), 1u);
  ASSERT_EQ(back.frames.at("fisheye").size(), sample.fisheye.size());
  for (size_t i = 0; i < sample.fisheye.size(); ++i) {
    const ImageFrame& frame = back.frames.at("fisheye")[i];
    EXPECT_EQ(frame.t, exact_time(ns(sample.fisheye[i].stamp))) << i;
    EXPECT_TRUE(samePixels(decode(frame), sample.fisheye[i].image)) << "fisheye frame " << i;
  }
  ASSERT_EQ(back.frames.count("cam03"), 1u);
  ASSERT_EQ(back.frames.at("cam03").size(), sample.cam03.size());
  for (size_t i = 0; i < sample.cam03.size(); ++i) {
    const ImageFrame& frame = back.frames.at("cam03")[i];
    EXPECT_EQ(frame.t, exact_time(ns(sample.cam03[i].stamp))) << i;
    EXPECT_TRUE(samePixels(decode(frame), sample.cam03[i].image)) << "cam03 frame " << i;
  }
  for (const auto& [label, expected] : std::map<std::string, const std::vector<SampleBag::Pose>*>{
           {"odometry", &sample.odometry}, {"ground_truth", &sample.ground_truth}}) {
    ASSERT_EQ(back.poses.count(label), 1u) << label;
    const auto& poses = back.poses.at(label);
    ASSERT_EQ(poses.size(), expected->size()) << label;
    for (size_t i = 0; i < poses.size(); ++i) {
      EXPECT_EQ(poses[i].t, exact_time(ns((*expected)[i].stamp))) << label << " " << i;
      EXPECT_LT((poses[i].world_from_body.translation - (*expected)[i].pose.translation).norm(),
                1e-9);
      EXPECT_LT(poses[i].world_from_body.rotation.angularDistance((*expected)[i].pose.rotation),
                1e-9);
    }
  }
}

TEST_F(RosbagImportTest, ImportsIntoAFolderDataset) {
  const fs::path bag = dir_ / "sample.bag";
  const SampleBag sample = writeSampleBag(bag);
  std::int64_t last_done = -1;
  std::int64_t last_total = -1;
  ProgressReporter progress([&](const ProgressEvent& e) {
    EXPECT_EQ(e.stage, "import");
    last_done = e.done;
    last_total = e.total;
  });
  const fs::path out = dir_ / "robot_run";
  const RosbagImportStats stats = importRosbag(bag, out, DatasetKind::kFolder, sampleOptions(),
                                               DatasetWriteOptions{}, progress);
  EXPECT_EQ(stats.records, 29);
  EXPECT_EQ(stats.messages_per_topic.at("/fisheye/image_raw"), 5);
  EXPECT_EQ(stats.messages_per_topic.at("/fisheye/camera_info"), 5);
  EXPECT_EQ(stats.messages_per_topic.at("/cam03/image/compressed"), 4);
  EXPECT_EQ(stats.messages_per_topic.at("/cam03/camera_info"), 1);
  EXPECT_EQ(stats.messages_per_topic.at("/odom"), 10);
  EXPECT_EQ(stats.messages_per_topic.at("/ground_truth/pose"), 10);
  EXPECT_EQ(stats.messages_per_topic.count("/chatter"), 0u);
  EXPECT_TRUE(stats.warnings.empty()) << stats.warnings.front();
  EXPECT_EQ(last_total, 35);
  EXPECT_EQ(last_done, 35);

  const ReadBack back = readBack(out);
  EXPECT_EQ(back.manifest.name, "robot_run");
  checkImported(sample, back, [](TimeNs t) { return t; });  // exact to the nanosecond
}

TEST_F(RosbagImportTest, ImportsIntoARawlogDataset) {
  const fs::path bag = dir_ / "sample.bag";
  BagVariant bz2;
  bz2.compression = rosbag::compression::BZ2;
  const SampleBag sample = writeSampleBag(bag, bz2);
  const fs::path out = dir_ / "robot_run.rawlog";
  const RosbagImportStats stats = importRosbag(bag, out, DatasetKind::kRawlog, sampleOptions(),
                                               DatasetWriteOptions{}, ProgressReporter{});
  EXPECT_EQ(stats.records, 29);
  const ReadBack back = readBack(out);
  EXPECT_EQ(back.manifest.name, "robot_run");
  // A rawlog holds MRPT's 100 ns ticks.
  checkImported(sample, back, [](TimeNs t) { return fromMrptTime(toMrptTime(t)); });
}

TEST_F(RosbagImportTest, UsesReceiveTimesWhenAsked) {
  const fs::path bag = dir_ / "sample.bag";
  BagVariant lz4;
  lz4.compression = rosbag::compression::LZ4;
  const SampleBag sample = writeSampleBag(bag, lz4);
  RosbagImportOptions options = sampleOptions();
  options.use_header_stamp = false;
  const fs::path out = dir_ / "received";
  importRosbag(bag, out, DatasetKind::kFolder, options, {}, {});
  const ReadBack back = readBack(out);
  ASSERT_EQ(back.frames.at("fisheye").size(), 5u);
  for (size_t i = 0; i < 5; ++i)
    EXPECT_EQ(back.frames.at("fisheye")[i].t, ns(sample.fisheye[i].received));
  ASSERT_EQ(back.poses.at("odometry").size(), 10u);
  for (size_t i = 0; i < 10; ++i)
    EXPECT_EQ(back.poses.at("odometry")[i].t, ns(sample.odometry[i].received));
}

TEST_F(RosbagImportTest, CalibrationFileOverridesCameraInfoAndJpegBytesAreKept) {
  const fs::path bag = dir_ / "sample.bag";
  const SampleBag sample = writeSampleBag(bag);
  // A ROS camera_info YAML for cam03 that differs from its CameraInfo topic, and one for cam04.
  const fs::path cam03_yaml = dir_ / "cam03.yaml";
  std::ofstream(cam03_yaml)
      << "image_width: 40\nimage_height: 30\ncamera_name: cam03\n"
         "camera_matrix: {rows: 3, cols: 3, data: [45, 0, 20, 0, 46, 15, 0, 0, 1]}\n"
         "distortion_model: plumb_bob\n"
         "distortion_coefficients: {rows: 1, cols: 5, data: [0, 0, 0, 0, 0]}\n";
  const fs::path cam04_yaml = dir_ / "cam04.yaml";
  std::ofstream(cam04_yaml)
      << "image_width: 36\nimage_height: 20\ncamera_name: cam04\n"
         "camera_matrix: {rows: 3, cols: 3, data: [20, 0, 17.5, 0, 20, 9.5, 0, 0, 1]}\n"
         "distortion_model: plumb_bob\n"
         "distortion_coefficients: {rows: 1, cols: 0, data: []}\n";
  RosbagImportOptions options = sampleOptions();
  options.topics.push_back({"/cam04/image/compressed", "cam04", "env_camera", true, "", "", ""});
  options.calibration_files["cam03"] = cam03_yaml;
  options.calibration_files["cam04"] = cam04_yaml;
  const fs::path out = dir_ / "with_files";
  const RosbagImportStats stats = importRosbag(bag, out, DatasetKind::kFolder, options, {}, {});
  ASSERT_EQ(stats.warnings.size(), 1u);
  EXPECT_NE(stats.warnings[0].find("/cam03/camera_info"), std::string::npos) << stats.warnings[0];
  EXPECT_NE(stats.warnings[0].find("using the file"), std::string::npos) << stats.warnings[0];

  const ReadBack back = readBack(out);
  ASSERT_EQ(back.manifest.cameras.size(), 3u);
  EXPECT_EQ(back.manifest.cameras[0].label, "fisheye");
  const CameraSensor* cam03 = back.manifest.findCamera("cam03");
  ASSERT_TRUE(cam03 && cam03->camera);
  EXPECT_EQ(cam03->camera->params()[0], 45.0);
  const CameraSensor* cam04 = back.manifest.findCamera("cam04");
  ASSERT_TRUE(cam04 && cam04->camera);
  EXPECT_EQ(cam04->camera->modelName(), "pinhole");
  ASSERT_EQ(back.frames.at("cam04").size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    const ImageFrame& frame = back.frames.at("cam04")[i];
    EXPECT_EQ(frame.t, ns(sample.cam04[i].stamp));
    // The JPEG bytes are kept: the decoded image is the JPEG's, not re-encoded.
    std::vector<uchar> jpeg;
    cv::imencode(".jpg", sample.cam04[i].image, jpeg);
    EXPECT_TRUE(samePixels(decode(frame), cv::imdecode(jpeg, cv::IMREAD_UNCHANGED))) << i;
  }
}

TEST_F(RosbagImportTest, WarnsOnceWhenCameraInfoChanges) {
  const fs::path bag = dir_ / "sample.bag";
  BagVariant changed;
  changed.change_fisheye_info = true;
  writeSampleBag(bag, changed);
  RosbagImportOptions options = sampleOptions();
  std::vector<std::string> printed;
  options.on_warning = [&](const std::string& w) { printed.push_back(w); };
  const RosbagImportStats stats =
      importRosbag(bag, dir_ / "changed", DatasetKind::kFolder, options, {}, {});
  ASSERT_EQ(printed.size(), 1u);
  EXPECT_EQ(stats.warnings, printed);
  EXPECT_NE(printed[0].find("/fisheye/camera_info"), std::string::npos) << printed[0];
  EXPECT_NE(printed[0].find("changes"), std::string::npos) << printed[0];
  const ReadBack back = readBack(dir_ / "changed");
  EXPECT_EQ(back.manifest.fisheye()->camera->params()[0], 30.0);  // the first one is kept
}

TEST_F(RosbagImportTest, ConvertsRawEncodings) {
  const fs::path bag = dir_ / "encodings.bag";
  const ros::Time t = rosTime(kSec0, 0);
  cv::Mat bgr(6, 8, CV_8UC3);
  cv::randu(bgr, cv::Scalar::all(0), cv::Scalar::all(255));
  cv::Mat mono16(6, 8, CV_16UC1);
  cv::randu(mono16, cv::Scalar::all(0), cv::Scalar::all(65535));
  {
    rosbag::Bag out(bag.string(), rosbag::bagmode::Write);
    sensor_msgs::Image rgb;
    rgb.header.stamp = t;
    rgb.width = 8;
    rgb.height = 6;
    rgb.encoding = "rgb8";
    rgb.step = 8 * 3 + 4;  // rows padded
    rgb.data.assign(rgb.step * 6, 0);
    for (int v = 0; v < 6; ++v) {
      for (int u = 0; u < 8; ++u) {
        const cv::Vec3b p = bgr.at<cv::Vec3b>(v, u);
        for (int c = 0; c < 3; ++c) rgb.data[v * rgb.step + u * 3 + c] = p[2 - c];
      }
    }
    out.write("/rgb", t, rgb);

    sensor_msgs::Image big;  // mono16, big-endian bytes
    big.header.stamp = t;
    big.width = 8;
    big.height = 6;
    big.encoding = "mono16";
    big.is_bigendian = 1;
    big.step = 16;
    for (int v = 0; v < 6; ++v) {
      for (int u = 0; u < 8; ++u) {
        const std::uint16_t value = mono16.at<std::uint16_t>(v, u);
        big.data.push_back(static_cast<std::uint8_t>(value >> 8));
        big.data.push_back(static_cast<std::uint8_t>(value & 0xFF));
      }
    }
    out.write("/mono16", t, big);

    sensor_msgs::Image bayer;  // uniform colour B=50 G=100 R=200 in an RGGB mosaic
    bayer.header.stamp = t;
    bayer.width = 8;
    bayer.height = 6;
    bayer.encoding = "bayer_rggb8";
    bayer.step = 8;
    for (int v = 0; v < 6; ++v) {
      for (int u = 0; u < 8; ++u) {
        const bool even_row = v % 2 == 0;
        const bool even_col = u % 2 == 0;
        bayer.data.push_back(even_row && even_col ? 200 : (!even_row && !even_col ? 50 : 100));
      }
    }
    out.write("/bayer", t, bayer);

    sensor_msgs::Image depth;
    depth.header.stamp = t;
    depth.width = 2;
    depth.height = 2;
    depth.encoding = "32FC1";
    depth.step = 8;
    depth.data.assign(16, 0);
    out.write("/depth", t, depth);
  }
  RosbagImportOptions options;
  options.on_warning = [](const std::string&) {};
  options.topics = {{"/rgb", "rgb", "env_camera", true, "", "", ""},
                    {"/mono16", "mono16", "env_camera", true, "", "", ""},
                    {"/bayer", "bayer", "env_camera", true, "", "", ""}};
  // The folder format needs calibrations; a rawlog does without.
  const std::string uncalibrated = errorOf(
      [&] { importRosbag(bag, dir_ / "encodings", DatasetKind::kFolder, options, {}, {}); });
  EXPECT_NE(uncalibrated.find("needs a calibration"), std::string::npos) << uncalibrated;
  EXPECT_NE(uncalibrated.find("rgb, mono16, bayer"), std::string::npos) << uncalibrated;
  EXPECT_FALSE(fs::exists(dir_ / "encodings"));
  const RosbagImportStats stats =
      importRosbag(bag, dir_ / "encodings.rawlog", DatasetKind::kRawlog, options, {}, {});
  ASSERT_EQ(stats.warnings.size(), 3u);
  EXPECT_NE(stats.warnings[0].find("'rgb' has no calibration"), std::string::npos)
      << stats.warnings[0];
  const ReadBack back = readBack(dir_ / "encodings.rawlog");
  EXPECT_FALSE(back.manifest.findCamera("rgb")->camera.has_value());
  EXPECT_EQ(back.frames.at("rgb").at(0).extension.empty()
                ? back.frames.at("rgb").at(0).image_file.extension().string()
                : back.frames.at("rgb").at(0).extension,
            ".png");
  EXPECT_TRUE(samePixels(decode(back.frames.at("rgb").at(0)), bgr));
  EXPECT_TRUE(samePixels(decode(back.frames.at("mono16").at(0)), mono16));
  const cv::Mat debayered = decode(back.frames.at("bayer").at(0));
  ASSERT_EQ(debayered.type(), CV_8UC3);
  EXPECT_EQ(debayered.at<cv::Vec3b>(3, 4), cv::Vec3b(50, 100, 200));  // an interior pixel, BGR

  options.topics.push_back({"/depth", "depth", "env_camera", true, "", "", ""});
  const std::string message = errorOf(
      [&] { importRosbag(bag, dir_ / "depth.rawlog", DatasetKind::kRawlog, options, {}, {}); });
  EXPECT_NE(message.find("/depth"), std::string::npos) << message;
  EXPECT_NE(message.find("32FC1"), std::string::npos) << message;
  EXPECT_NE(message.find("encodings.bag"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(dir_ / "depth.rawlog"));
  EXPECT_FALSE(fs::exists(dir_ / "depth.yaml"));
}

TEST_F(RosbagImportTest, PosesAndStampsAreChecked) {
  const fs::path bag = dir_ / "poses.bag";
  {
    rosbag::Bag out(bag.string(), rosbag::bagmode::Write);
    for (int i = 0; i < 4; ++i) {
      geometry_msgs::PoseStamped pose;
      pose.header.stamp = rosTime(kSec0, i < 2 ? 0 : 1000 * i);  // the 2nd repeats the 1st
      pose.pose = toRos(samplePose(i, 0.0));
      out.write("/good", rosTime(kSec0, 1 + i), pose);
      pose.pose.orientation.w = 0.0;  // not a unit quaternion
      pose.pose.orientation.x = 0.0;
      pose.pose.orientation.y = 0.0;
      pose.pose.orientation.z = 0.0;
      out.write("/zero_quaternion", rosTime(kSec0, 1 + i), pose);
      geometry_msgs::PoseStamped unstamped;
      unstamped.pose = toRos(samplePose(i, 0.0));
      out.write("/unstamped", rosTime(kSec0, 1 + i), unstamped);
    }
  }
  RosbagImportOptions options;
  std::vector<std::string> warnings;
  options.on_warning = [&](const std::string& w) { warnings.push_back(w); };
  options.topics = {{"/good", "vo", "odometry", false, "", "", ""}};
  const RosbagImportStats stats =
      importRosbag(bag, dir_ / "good", DatasetKind::kFolder, options, {}, {});
  EXPECT_EQ(stats.messages_per_topic.at("/good"), 4);
  EXPECT_EQ(stats.records, 3);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("repeat"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("'vo'"), std::string::npos) << warnings[0];
  const ReadBack back = readBack(dir_ / "good");
  ASSERT_EQ(back.poses.at("vo").size(), 3u);
  EXPECT_FALSE(back.manifest.findTrajectory("vo")->metric);

  options.topics = {{"/zero_quaternion", "odometry", "odometry", true, "", "", ""}};
  std::string message =
      errorOf([&] { importRosbag(bag, dir_ / "bad", DatasetKind::kFolder, options, {}, {}); });
  EXPECT_NE(message.find("/zero_quaternion"), std::string::npos) << message;
  EXPECT_NE(message.find("norm"), std::string::npos) << message;

  options.topics = {{"/unstamped", "odometry", "odometry", true, "", "", ""}};
  message =
      errorOf([&] { importRosbag(bag, dir_ / "bad", DatasetKind::kFolder, options, {}, {}); });
  EXPECT_NE(message.find("/unstamped"), std::string::npos) << message;
  EXPECT_NE(message.find("use_header_stamp"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(dir_ / "bad"));
  // With the receive times instead, it imports.
  options.use_header_stamp = false;
  EXPECT_EQ(importRosbag(bag, dir_ / "received", DatasetKind::kFolder, options, {}, {}).records, 4);
}

TEST_F(RosbagImportTest, MissingTopicListsTheTopicsPresent) {
  const fs::path bag = dir_ / "sample.bag";
  writeSampleBag(bag);
  RosbagImportOptions options = sampleOptions();
  options.topics.push_back({"/cam07/image_raw", "cam07", "env_camera", true, "", "", ""});
  const fs::path out = dir_ / "out";
  const std::string message =
      errorOf([&] { importRosbag(bag, out, DatasetKind::kFolder, options, {}, {}); });
  EXPECT_NE(message.find("/cam07/image_raw"), std::string::npos) << message;
  EXPECT_NE(message.find("not in the bag"), std::string::npos) << message;
  EXPECT_NE(message.find("/fisheye/image_raw (sensor_msgs/Image)"), std::string::npos) << message;
  EXPECT_NE(message.find("/odom (nav_msgs/Odometry)"), std::string::npos) << message;
  EXPECT_NE(message.find("/chatter (std_msgs/String)"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(RosbagImportTest, UnsupportedTypeNamesTopicAndType) {
  const fs::path bag = dir_ / "sample.bag";
  writeSampleBag(bag);
  RosbagImportOptions options = sampleOptions();
  options.topics.push_back({"/chatter", "chatter", "odometry", true, "", "", ""});
  const std::string message =
      errorOf([&] { importRosbag(bag, dir_ / "out", DatasetKind::kFolder, options, {}, {}); });
  EXPECT_NE(message.find("/chatter"), std::string::npos) << message;
  EXPECT_NE(message.find("std_msgs/String"), std::string::npos) << message;
  EXPECT_NE(message.find("unsupported"), std::string::npos) << message;

  // A supported type under the wrong role.
  RosbagImportOptions wrong_role = sampleOptions();
  wrong_role.topics[4].role = "env_camera";  // /odom
  wrong_role.topics[4].metric = true;
  const std::string role_message =
      errorOf([&] { importRosbag(bag, dir_ / "out", DatasetKind::kFolder, wrong_role, {}, {}); });
  EXPECT_NE(role_message.find("/odom"), std::string::npos) << role_message;
  EXPECT_NE(role_message.find("nav_msgs/Odometry"), std::string::npos) << role_message;
  EXPECT_FALSE(fs::exists(dir_ / "out"));
}

TEST_F(RosbagImportTest, ImageSizeDifferentFromCalibrationNamesTopicAndSizes) {
  const fs::path bag = dir_ / "sample.bag";
  writeSampleBag(bag);
  const fs::path yaml = dir_ / "cam03_vga.yaml";
  std::ofstream(yaml)
      << "image_width: 640\nimage_height: 480\n"
         "camera_matrix: {rows: 3, cols: 3, data: [500, 0, 319.5, 0, 500, 239.5, 0, 0, 1]}\n"
         "distortion_model: plumb_bob\n"
         "distortion_coefficients: {rows: 1, cols: 5, data: [0, 0, 0, 0, 0]}\n";
  RosbagImportOptions options = sampleOptions();
  options.calibration_files["cam03"] = yaml;
  const fs::path out = dir_ / "out";
  const std::string message =
      errorOf([&] { importRosbag(bag, out, DatasetKind::kFolder, options, {}, {}); });
  EXPECT_NE(message.find("/cam03/image/compressed"), std::string::npos) << message;
  EXPECT_NE(message.find("40x30"), std::string::npos) << message;
  EXPECT_NE(message.find("640x480"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(RosbagImportTest, CorruptOrTruncatedBagIsAnErrorNamingTheBag) {
  const fs::path garbage = dir_ / "garbage.bag";
  {
    std::ofstream out(garbage, std::ios::binary);
    for (int i = 0; i < 5000; ++i) out.put(static_cast<char>((i * 7919) % 251));
  }
  const fs::path out = dir_ / "out";
  std::string message =
      errorOf([&] { importRosbag(garbage, out, DatasetKind::kFolder, sampleOptions(), {}, {}); });
  EXPECT_NE(message.find(garbage.string()), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));

  // A good bag cut in half (an interrupted copy).
  const fs::path good = dir_ / "good.bag";
  writeSampleBag(good);
  const fs::path cut = dir_ / "cut.bag";
  {
    std::ifstream in(good, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  message = errorOf([&] { importRosbag(cut, out, DatasetKind::kFolder, sampleOptions(), {}, {}); });
  EXPECT_NE(message.find(cut.string()), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));

  message = errorOf([&] {
    importRosbag(dir_ / "absent.bag", out, DatasetKind::kFolder, sampleOptions(), {}, {});
  });
  EXPECT_NE(message.find("absent.bag"), std::string::npos) << message;
}

// ---------------------------------------------------------------------------
// Corrupted bags: rosbag_storage trusts the lengths and positions of a bag,
// so every corruption below must be stopped by the import's own structure
// check (an Error naming the bag), never reach a crash in the library.

std::string readBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void writeBytes(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

std::uint32_t get32(const std::string& b, size_t at) {
  std::uint32_t v = 0;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

void put32(std::string& b, size_t at, std::uint32_t v) { std::memcpy(b.data() + at, &v, 4); }

/// Positions of the 4-byte length and position fields of a bag 2.0: every
/// record's header and data lengths, each header field's length, the
/// numbers in its fields, the index entries' offsets, and the same inside
/// uncompressed chunks.
std::vector<size_t> lengthFields(const std::string& b) {
  std::vector<size_t> at;
  std::function<void(size_t, size_t)> walk = [&](size_t begin, size_t end) {
    size_t o = begin;
    while (o + 8 <= end) {
      const std::uint32_t header = get32(b, o);
      at.push_back(o);
      size_t i = o + 4;
      std::string op;
      bool compressed = false;
      while (i < o + 4 + header) {
        const std::uint32_t length = get32(b, i);
        at.push_back(i);
        const std::string fieldText = b.substr(i + 4, length);
        const size_t equals = fieldText.find('=');
        const size_t value = i + 4 + equals + 1;
        if (length - equals - 1 >= 4) at.push_back(value);  // u32, u64 (low half), time
        if (fieldText.rfind("op=", 0) == 0) op = fieldText.substr(3);
        if (fieldText.rfind("compression=", 0) == 0) compressed = fieldText != "compression=none";
        i += 4 + length;
      }
      const std::uint32_t data = get32(b, i);
      at.push_back(i);
      if (op == "\x05" && !compressed) walk(i + 4, i + 4 + data);
      if (op == "\x04") {
        for (size_t k = 0; k + 12 <= data; k += 12) at.push_back(i + 4 + k + 8);
      }
      o = i + 4 + data;
    }
  };
  walk(13, b.size());
  return at;
}

/// Position of the offset field of the first index entry after chunk `n` (1-based).
size_t firstIndexEntryAfterChunk(const std::string& b, int n) {
  int chunks = 0;
  for (size_t o = 13; o + 8 <= b.size();) {
    const std::uint32_t header = get32(b, o);
    const bool chunk = b.find("op=\x05", o + 4) < o + 4 + header;
    const bool index = b.find("op=\x04", o + 4) < o + 4 + header;
    const size_t data = o + 4 + header + 4;
    if (index && chunks == n) return data + 8;
    chunks += chunk;
    o = data + get32(b, data - 4);
  }
  return 0;
}

TEST_F(RosbagImportTest, CorruptedBagsAreErrorsNeverCrashes) {
  const fs::path good = dir_ / "good.bag";
  writeSampleBag(good);
  const std::string original = readBytes(good);
  const fs::path bag = dir_ / "corrupt.bag";
  const fs::path out = dir_ / "out";
  DatasetWriteOptions overwrite;
  overwrite.overwrite = true;
  int errors = 0;
  int imported = 0;
  auto importCorrupted = [&](const std::string& bytes, const std::string& what) {
    writeBytes(bag, bytes);
    try {
      importRosbag(bag, out, DatasetKind::kFolder, sampleOptions(), overwrite, {});
      ++imported;
    } catch (const Error& e) {
      ++errors;
      EXPECT_NE(std::string(e.what()).find(bag.string()), std::string::npos)
          << what << ": " << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": not a lookboth::Error: " << e.what();
    }
    for (const auto& entry : fs::directory_iterator(dir_)) {
      const std::string name = entry.path().filename().string();
      EXPECT_TRUE(name == "good.bag" || name == "corrupt.bag" || name == "out")
          << what << ": left behind " << name;
    }
  };

  // The offset of the first index entry after the third chunk (bytes
  // 33721..33724 of the sample bag) pointing 2 GiB into the chunk, which
  // crashed rosbag_storage: an error naming the bag and the chunk.
  std::string bytes = original;
  const std::vector<size_t> fields = lengthFields(original);
  const size_t entry = firstIndexEntryAfterChunk(original, 3);
  ASSERT_GT(entry, 0u);
  EXPECT_EQ(entry, 33721u);  // as in the end-to-end test's sample.bag
  put32(bytes, entry, 0x7fffffff);
  writeBytes(bag, bytes);
  const std::string message =
      errorOf([&] { importRosbag(bag, out, DatasetKind::kFolder, sampleOptions(), {}, {}); });
  EXPECT_NE(message.find(bag.string()), std::string::npos) << message;
  EXPECT_NE(message.find("corrupt ROS bag"), std::string::npos) << message;
  EXPECT_NE(message.find("chunk 3 of"), std::string::npos) << message;
  EXPECT_NE(message.find("2147483647"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(out));

  // A smaller bag of the same kinds of records, for speed: each of its
  // length or position fields set to a value that points nowhere (six kinds
  // in turn), then random bytes anywhere, and cuts.
  BagVariant small;
  small.small = true;
  writeSampleBag(good, small);
  const std::string sample = readBytes(good);
  const std::vector<size_t> small_fields = lengthFields(sample);
  ASSERT_GT(small_fields.size(), 150u);
  std::mt19937 rng(20240611);
  for (size_t k = 0; k < small_fields.size(); ++k) {
    const size_t at = small_fields[k];
    const std::uint32_t value = get32(sample, at);
    const std::uint32_t kinds[] = {0xffffffffu,
                                   0x7fffffffu,
                                   value + 1,
                                   value - 1,
                                   static_cast<std::uint32_t>(sample.size()),
                                   static_cast<std::uint32_t>(rng())};
    bytes = sample;
    put32(bytes, at, kinds[k % 6]);
    importCorrupted(bytes,
                    "field at byte " + std::to_string(at) + " = " + std::to_string(kinds[k % 6]));
  }
  for (int round = 0; round < 100; ++round) {
    bytes = sample;
    const int flips = 1 + static_cast<int>(rng() % 8);
    for (int k = 0; k < flips; ++k) bytes[rng() % bytes.size()] = static_cast<char>(rng());
    if (round % 10 == 0) bytes.resize(13 + rng() % (bytes.size() - 13));
    importCorrupted(bytes, "round " + std::to_string(round));
  }
  EXPECT_GT(errors, static_cast<int>(small_fields.size()) / 2);
  std::printf("corrupted bags: %d errors, %d imported\n", errors, imported);
}

TEST_F(RosbagImportTest, CorruptedCompressedBagsAreErrorsNeverCrashes) {
  for (const auto compression : {rosbag::compression::BZ2, rosbag::compression::LZ4}) {
    BagVariant variant;
    variant.compression = compression;
    variant.small = true;
    const fs::path good = dir_ / "good.bag";
    writeSampleBag(good, variant);
    const std::string original = readBytes(good);
    const fs::path bag = dir_ / "corrupt.bag";
    DatasetWriteOptions overwrite;
    overwrite.overwrite = true;
    std::mt19937 rng(7 + static_cast<int>(compression));
    const std::vector<size_t> fields = lengthFields(original);
    for (int round = 0; round < 60; ++round) {
      std::string bytes = original;
      if (round % 2 == 0) {
        put32(bytes, fields[rng() % fields.size()],
              round % 4 == 0 ? 0xffffffffu : static_cast<std::uint32_t>(rng()));
      } else {
        for (int k = 0; k < 4; ++k) bytes[rng() % bytes.size()] = static_cast<char>(rng());
      }
      writeBytes(bag, bytes);
      try {
        importRosbag(bag, dir_ / "out", DatasetKind::kFolder, sampleOptions(), overwrite, {});
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(bag.string()), std::string::npos) << e.what();
      } catch (const std::exception& e) {
        ADD_FAILURE() << "round " << round << ": not a lookboth::Error: " << e.what();
      }
    }
  }
}

TEST_F(RosbagImportTest, StopRequestLeavesNothing) {
  const fs::path bag = dir_ / "sample.bag";
  writeSampleBag(bag);
  // The callback asks its own reporter to stop, as a GUI's stop button would.
  ProgressReporter stopping([&stopping](const ProgressEvent& e) {
    if (e.done == 7) stopping.requestStop();
  });
  const fs::path out = dir_ / "stopped.rawlog";
  EXPECT_THROW(importRosbag(bag, out, DatasetKind::kRawlog, sampleOptions(), {}, stopping),
               StopRequested);
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(dir_ / "stopped.yaml"));
  EXPECT_FALSE(fs::exists(dir_ / "stopped_Images"));
}

TEST_F(RosbagImportTest, RefusesToOverwriteAnExistingOutput) {
  const fs::path bag = dir_ / "sample.bag";
  writeSampleBag(bag);
  const fs::path out = dir_ / "existing";
  fs::create_directories(out);
  const std::string message =
      errorOf([&] { importRosbag(bag, out, DatasetKind::kFolder, sampleOptions(), {}, {}); });
  EXPECT_NE(message.find("existing"), std::string::npos) << message;
  DatasetWriteOptions overwrite;
  overwrite.overwrite = true;
  EXPECT_NO_THROW(importRosbag(bag, out, DatasetKind::kFolder, sampleOptions(), overwrite, {}));
}

// ---------------------------------------------------------------------------
// Mapping: YAML, command line, check()

TEST_F(RosbagImportTest, LoadsAMappingYaml) {
  const fs::path yaml = dir_ / "config" / "mapping.yaml";
  fs::create_directories(yaml.parent_path());
  std::ofstream(yaml) << "# which topic is what\n"
                         "topics:\n"
                         "  /fisheye/image_raw: {label: fisheye, role: fisheye}\n"
                         "  /fisheye/camera_info: {role: fisheye}\n"
                         "  /cam03/image/compressed: {label: cam03, role: env_camera}\n"
                         "  /vo/pose: {label: vo, role: odometry, metric: false}\n"
                         "  /gt: {role: ground_truth}\n"
                         "marker: {dictionary: DICT_4X4_50, id: 3, size_m: 0.2}\n"
                         "calibrations: {cam03: calib/cam03.yaml}\n"
                         "use_header_stamp: false\n";
  const RosbagImportOptions options = loadRosbagMapping(yaml);
  ASSERT_EQ(options.topics.size(), 5u);
  EXPECT_EQ(options.topics[0].topic, "/fisheye/image_raw");
  EXPECT_EQ(options.topics[0].label, "fisheye");
  EXPECT_EQ(RosbagImportOptions::effectiveLabel(options.topics[1]), "fisheye");
  EXPECT_EQ(options.topics[2].role, "env_camera");
  EXPECT_EQ(options.topics[3].label, "vo");
  EXPECT_FALSE(options.topics[3].metric);
  EXPECT_TRUE(options.topics[0].metric);
  EXPECT_EQ(RosbagImportOptions::effectiveLabel(options.topics[4]), "ground_truth");
  EXPECT_EQ(options.marker.id, 3);
  EXPECT_EQ(options.calibration_files.at("cam03"), yaml.parent_path() / "calib/cam03.yaml");
  EXPECT_FALSE(options.use_header_stamp);
  EXPECT_EQ(options.check(), "");
}

TEST_F(RosbagImportTest, BadMappingYamlNamesTheField) {
  const std::string marker = "marker: {dictionary: DICT_4X4_50, id: 0, size_m: 0.2}\n";
  const std::vector<std::pair<std::string, std::vector<std::string>>> cases = {
      {"topics:\n  /odom: {label: odometry, role: odom}\n" + marker,
       {"topics./odom.role", ":2:", "odom"}},
      {"topics:\n  /odom: {label: odometry}\n" + marker, {"topics./odom.role", "missing"}},
      {"topics:\n  /odom: {label: odometry, role: odometry, metric: maybe}\n" + marker,
       {"topics./odom.metric", "maybe"}},
      {"topics:\n  /odom: {label: odometry, role: odometry, colour: red}\n" + marker,
       {"topics./odom.colour", "unknown key"}},
      {"topics:\n  /odom: {label: odometry, role: odometry}\n", {"'marker'", "missing"}},
      {"topics:\n  /odom: {role: odometry}\nmarker: {dictionary: DICT_9X9_1, id: 0, size_m: 0.2}\n",
       {"dictionary", "DICT_9X9_1"}},
      {"topics:\n  /odom: {role: odometry}\nmarker: {dictionary: DICT_4X4_50, id: 0, size_m: -1}\n",
       {"size_m"}},
      {"topics:\n  /odom: {role: odometry}\n" + marker + "calibrations: {cam09: x.yaml}\n",
       {"calibrations.cam09"}},
      {"topics:\n  /a: {label: cam01, role: env_camera}\n  /b: {label: cam01, role: fisheye}\n" +
           marker,
       {"topics[/b].label", "cam01"}},
      {"topics:\n  /gt: {label: truth, role: ground_truth}\n" + marker,
       {"topics[/gt].label", "ground_truth"}},
      {"topics:\n  /cam: {role: env_camera}\n" + marker, {"topics[/cam].label", "missing"}},
      {"topics: [/odom]\n" + marker, {"'topics'", "mapping"}},
      {"topics: {/odom: {role: odometry}\n", {"not valid YAML"}},
      {"tpoics:\n  /odom: {role: odometry}\n" + marker, {"tpoics", "unknown key"}},
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const fs::path yaml = dir_ / ("bad" + std::to_string(i) + ".yaml");
    std::ofstream(yaml) << cases[i].first;
    const std::string message = errorOf([&] { loadRosbagMapping(yaml); });
    EXPECT_NE(message.find(yaml.string()), std::string::npos) << "case " << i << ": " << message;
    for (const std::string& expected : cases[i].second) {
      EXPECT_NE(message.find(expected), std::string::npos)
          << "case " << i << " lacks '" << expected << "': " << message;
    }
  }
  const std::string missing = errorOf([&] { loadRosbagMapping(dir_ / "nope.yaml"); });
  EXPECT_NE(missing.find("nope.yaml"), std::string::npos) << missing;
}

TEST(RosTopicMapping, ParsesTheCommandLineForm) {
  RosTopicMapping m = parseTopicMapping("/cam03/image/compressed=cam03:env_camera");
  EXPECT_EQ(m.topic, "/cam03/image/compressed");
  EXPECT_EQ(m.label, "cam03");
  EXPECT_EQ(m.role, "env_camera");
  EXPECT_TRUE(m.metric);
  m = parseTopicMapping("/orb/pose=vo:odometry:nonmetric");
  EXPECT_EQ(m.label, "vo");
  EXPECT_EQ(m.role, "odometry");
  EXPECT_FALSE(m.metric);
  m = parseTopicMapping("/gt=:ground_truth");
  EXPECT_EQ(m.label, "");
  EXPECT_EQ(RosbagImportOptions::effectiveLabel(m), "ground_truth");

  for (const std::string bad :
       {"/odom", "=odometry:odometry", "/odom=odometry", "/odom=odometry:odom",
        "/odom=odometry:odometry:sometimes", "/cam=cam:env_camera:nonmetric"}) {
    const std::string message = errorOf([&] { parseTopicMapping(bad); });
    EXPECT_NE(message.find("'" + bad + "'"), std::string::npos) << message;
  }
}

TEST(RosbagImportOptions, CheckNamesTheField) {
  RosbagImportOptions options;
  EXPECT_NE(options.check().find("'topics'"), std::string::npos);
  options.topics = {{"/a", "fish", "fisheye", true, "", "", ""},
                    {"/b", "fish2", "fisheye", true, "", "", ""}};
  EXPECT_NE(options.check().find("topics[/b].label"), std::string::npos) << options.check();
  options.topics = {{"/a", "odometry", "odometry", true, "", "", ""},
                    {"/a", "odometry", "odometry", true, "", "", ""}};
  EXPECT_NE(options.check().find("topics[/a]"), std::string::npos) << options.check();
  options.topics = {{"/a", "odometry", "odometry", true, "", "", ""},
                    {"/b", "odometry", "odometry", true, "", "", ""}};
  EXPECT_NE(options.check().find("topics[/b].label"), std::string::npos) << options.check();
  options.topics = {{"/a", "cam 1", "env_camera", true, "", "", ""}};
  EXPECT_NE(options.check().find("topics[/a].label"), std::string::npos) << options.check();
  options.topics = {{"/a", "cam1", "env_camera", true, "", "", ""}};
  EXPECT_EQ(options.check(), "");
  options.marker.id = 5000;
  EXPECT_NE(options.check().find("'id'"), std::string::npos) << options.check();
}

}  // namespace
}  // namespace lookboth

namespace lookboth {
namespace {

// Writes the sample bag where $LOOKBOTH_SAMPLE_BAG says, for the end-to-end
// test of `lookboth convert` (tests/convert_bag_e2e.cmake); skipped otherwise.
TEST(RosbagSample, WritesTheSampleBagForTheEndToEndTest) {
  const char* path = std::getenv("LOOKBOTH_SAMPLE_BAG");
  if (!path) GTEST_SKIP() << "LOOKBOTH_SAMPLE_BAG not set";
  writeSampleBag(path);
  EXPECT_TRUE(fs::exists(path));
}

}  // namespace
}  // namespace lookboth
