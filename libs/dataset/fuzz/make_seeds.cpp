// lookboth-fuzz-seeds <target> <dir>: writes the seed corpus of one fuzz
// target into <dir> (scripts/fuzz.sh calls it before each run). Seeds are
// the repository's own sample files (share/lookboth, tests/data) and small
// datasets and bags written here, so nothing binary is kept in the repository.
#include <geometry_msgs/PoseStamped.h>
#include <mrpt/io/CFileGZInputStream.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cstdio>
#include <exception>
#include <fstream>
#include <string>
#include <vector>

#include "fuzz_dataset.h"
#include "lookboth/core/atomic_file.h"

namespace {

namespace fs = std::filesystem;
using lookboth::fuzz::folderSample;

const fs::path kShare = LOOKBOTH_SHARE_DIR;
const fs::path kTestData = LOOKBOTH_TEST_DATA_DIR;

void writeText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

/// Copies every file of `from` (not recursing) into `to`, prefixed with `prefix`.
void copyFiles(const fs::path& from, const fs::path& to, const std::string& prefix) {
  for (const auto& entry : fs::directory_iterator(from)) {
    if (entry.is_regular_file()) {
      fs::copy_file(entry.path(), to / (prefix + entry.path().filename().string()),
                    fs::copy_options::overwrite_existing);
    }
  }
}

std::string gunzip(const fs::path& path) {
  mrpt::io::CFileGZInputStream in(path.string());
  std::string bytes;
  char buffer[1 << 16];
  while (const size_t n = in.Read(buffer, sizeof buffer)) bytes.append(buffer, n);
  return bytes;
}

void rawlogSeeds(const fs::path& dir, const fs::path& work) {
  const fs::path rawlog = work / "sample.rawlog";
  lookboth::fuzz::writeSampleRawlog(rawlog);
  writeText(dir / "sample.rawlog", gunzip(rawlog));
  fs::copy_file(rawlog, dir / "sample.rawlog.gz", fs::copy_options::overwrite_existing);
}

void manifestSeeds(const fs::path& dir, const fs::path& work) {
  const fs::path rawlog = work / "sample.rawlog";
  lookboth::fuzz::writeSampleRawlog(rawlog);
  fs::copy_file(lookboth::manifestPathFor(rawlog), dir / "sample.yaml",
                fs::copy_options::overwrite_existing);
  lookboth::Manifest bare;
  bare.name = "bare";
  writeText(dir / "bare.yaml", lookboth::manifestToYaml(bare));
  writeText(dir / "uncalibrated.yaml",
            lookboth::manifestToYaml(lookboth::fuzz::fuzzManifest(/*calibrated=*/false)));
}

void folderSeeds(const fs::path& dir) {
  const std::vector<fs::path> files = lookboth::fuzz::folderTextFiles(folderSample());
  for (size_t i = 0; i < files.size(); ++i) {
    std::string seed(1, static_cast<char>(i));
    seed += lookboth::readFile(folderSample() / files[i]);
    std::string name = files[i].generic_string();
    for (char& c : name) c = c == '/' ? '_' : c;
    writeText(dir / name, seed);
  }
}

ros::Time stamp(int i) { return ros::Time(1700000000, 40'000'000 * static_cast<unsigned>(i) + 7); }

sensor_msgs::CameraInfo pinholeInfo(const ros::Time& t, int width, int height) {
  sensor_msgs::CameraInfo info;
  info.header.stamp = t;
  info.width = static_cast<std::uint32_t>(width);
  info.height = static_cast<std::uint32_t>(height);
  info.distortion_model = "plumb_bob";
  info.D = {0.01, -0.002, 0.0, 0.0, 0.0};
  const double f = 0.5 * width;
  info.K = {f, 0, 0.5 * (width - 1), 0, f, 0.5 * (height - 1), 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {f, 0, 0.5 * (width - 1), 0, 0, f, 0.5 * (height - 1), 0, 0, 0, 1, 0};
  return info;
}

geometry_msgs::Pose rosPose(int i) {
  geometry_msgs::Pose pose;
  pose.position.x = 0.1 * i;
  pose.position.y = -0.05 * i;
  pose.orientation.z = std::sin(0.05 * i);
  pose.orientation.w = std::cos(0.05 * i);
  return pose;
}

void writeBag(const fs::path& path, rosbag::compression::CompressionType compression) {
  rosbag::Bag bag(path.string(), rosbag::bagmode::Write);
  bag.setCompression(compression);
  bag.setChunkThreshold(4096);  // more than one chunk, so that the index spans several
  const int width = 8, height = 6;
  for (int i = 0; i < 3; ++i) {
    const ros::Time t = stamp(i);
    const ros::Time received = t + ros::Duration(0, 1'000'000);
    sensor_msgs::Image image;
    image.header.stamp = t;
    image.header.frame_id = "fisheye";
    image.width = width;
    image.height = height;
    image.encoding = i == 1 ? "bgr8" : "mono8";
    image.step = static_cast<std::uint32_t>(width * (i == 1 ? 3 : 1));
    image.data.assign(image.step * height, static_cast<std::uint8_t>(30 * i));
    bag.write("/fisheye/image_raw", received, image);
    bag.write("/fisheye/camera_info", received, pinholeInfo(t, width, height));

    if (i < 2) {
      sensor_msgs::CompressedImage compressed;
      compressed.header.stamp = t + ros::Duration(0, 300);
      compressed.format = "mono8; png compressed";
      const std::shared_ptr<const std::vector<std::uint8_t>> png = lookboth::fuzz::tinyPng(90);
      compressed.data.assign(png->begin(), png->end());
      if (i == 0) bag.write("/cam03/camera_info", received, pinholeInfo(t, width, height));
      bag.write("/cam03/image/compressed", received, compressed);
    }

    nav_msgs::Odometry odometry;
    odometry.header.stamp = t + ros::Duration(0, 500);
    odometry.header.frame_id = "odom";
    odometry.child_frame_id = "base_link";
    odometry.pose.pose = rosPose(i);
    bag.write("/odom", received, odometry);

    geometry_msgs::PoseStamped truth;
    truth.header.stamp = t + ros::Duration(0, 700);
    truth.pose = rosPose(i);
    bag.write("/ground_truth/pose", received, truth);
  }
  bag.close();
}

void rosbagSeeds(const fs::path& dir) {
  writeBag(dir / "plain.bag", rosbag::compression::Uncompressed);
  writeBag(dir / "bz2.bag", rosbag::compression::BZ2);
  writeBag(dir / "lz4.bag", rosbag::compression::LZ4);
}

void configSeeds(const fs::path& dir) {
  copyFiles(kShare / "config", dir, "share_");
  copyFiles(kTestData / "config", dir, "tests_");
  copyFiles(kTestData / "calib", dir, "tests_calib_");
  // A topic mapping of `lookboth convert --mapping` (rosbag_import.h).
  writeText(dir / "rosbag_mapping.yaml",
            "topics:\n"
            "  /fisheye/image_raw: {label: fisheye, role: fisheye}\n"
            "  /fisheye/camera_info: {role: fisheye}\n"
            "  /cam03/image/compressed: {label: cam03, role: env_camera}\n"
            "  /odom: {label: odometry, role: odometry, metric: false}\n"
            "  /truth: {role: ground_truth}\n"
            "marker: {dictionary: DICT_4X4_50, id: 0, size_m: 0.2}\n"
            "calibrations: {cam03: " +
                (kShare / "cameras" / "ceiling_camera_ros.yaml").string() +
                "}\n"
                "use_header_stamp: false\n");
}

void cameraSeeds(const fs::path& dir) {
  copyFiles(kShare / "cameras", dir, "share_");
  copyFiles(kTestData / "cameras", dir, "tests_");
  for (const auto& entry : fs::recursive_directory_iterator(folderSample())) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file() && (name == "calibration.yaml" || name == "calib_results.txt")) {
      fs::copy_file(entry.path(),
                    dir / ("folder_" + entry.path().parent_path().filename().string() + "_" + name),
                    fs::copy_options::overwrite_existing);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s <fuzz target> <corpus folder>\n", argv[0]);
    return 2;
  }
  const std::string target = argv[1];
  const fs::path dir = argv[2];
  try {
    fs::create_directories(dir);
    const fs::path work = dir / ".seed-work";
    fs::create_directories(work);
    if (target == "rawlog") {
      rawlogSeeds(dir, work);
    } else if (target == "manifest") {
      manifestSeeds(dir, work);
    } else if (target == "folder") {
      folderSeeds(dir);
    } else if (target == "rosbag") {
      rosbagSeeds(dir);
    } else if (target == "mcap") {
      // The MCAP fixtures written by the npm MCAP library (tests/data/ros2).
      for (const char* name : {"sample_uncompressed.mcap", "sample_lz4.mcap", "sample_zstd.mcap",
                               "sample_unchunked.mcap", "sample_nosummary.mcap"}) {
        fs::copy_file(kTestData / "ros2" / name, dir / name, fs::copy_options::overwrite_existing);
      }
    } else if (target == "config") {
      configSeeds(dir);
    } else if (target == "camera") {
      cameraSeeds(dir);
    } else if (target == "scenario") {
      copyFiles(kShare / "scenarios", dir, "share_");
    } else {
      std::fprintf(stderr, "lookboth-fuzz-seeds: unknown fuzz target '%s'\n", target.c_str());
      return 2;
    }
    fs::remove_all(work);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lookboth-fuzz-seeds: %s\n", e.what());
    return 1;
  }
  return 0;
}
