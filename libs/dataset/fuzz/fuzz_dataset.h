// What the dataset fuzz targets and their seed maker (make_seeds.cpp) share:
// a small dataset holding every kind of record, the bag topics of the seed
// bag, and the files of the folder sample that the folder target rewrites.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/dataset/rosbag_import.h"

namespace lookboth::fuzz {

/// The dataset written by writeSampleRawlog: a fisheye and one environment
/// camera, both trajectories and every ground truth field. Without
/// calibrations when `calibrated` is false: building a camera model is most
/// of the time of reading a small dataset in a sanitizer build, and the rawlog
/// reader does not use them.
inline Manifest fuzzManifest(bool calibrated = true) {
  const std::filesystem::path cameras = std::filesystem::path(LOOKBOTH_SHARE_DIR) / "cameras";
  auto calibration = [&](const char* file) -> std::optional<Camera> {
    if (!calibrated) return std::nullopt;
    return loadCamera(cameras / file);
  };
  Manifest m;
  m.name = "sample";
  m.marker = {"DICT_5X5_100", 3, 0.15};
  m.cameras.push_back(
      {"fisheye", SensorRole::kFisheye, calibration("fisheye_640x360_calib_results.txt")});
  m.cameras.push_back(
      {"cam03", SensorRole::kEnvCamera, calibration("ceiling_camera_640x360_ros.yaml")});
  m.trajectories.push_back({"odometry", true, "wheels"});
  m.trajectories.push_back({"ground_truth", true, "simulated"});
  m.ground_truth.world_from_camera["cam03"] =
      Rigid3d(Eigen::Quaterniond(0.0, 0.0, 1.0, 0.0), Eigen::Vector3d(1.5, -0.5, 3.0));
  m.ground_truth.fisheye_from_marker =
      Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, -0.15, -0.05));
  m.ground_truth.clock_offset["cam03"] = -1'500'000;
  return m;
}

inline std::shared_ptr<const std::vector<std::uint8_t>> tinyPng(int shade) {
  const cv::Mat image(6, 8, CV_8UC1, cv::Scalar(shade));
  std::vector<uchar> png;
  cv::imencode(".png", image, png);
  return std::make_shared<const std::vector<std::uint8_t>>(png.begin(), png.end());
}

/// Two of each record kind, in time order, on MRPT's 100 ns clock ticks; the
/// markers carry corners.
inline std::vector<Record> fuzzRecords() {
  std::vector<Record> records;
  const TimeNs start = secondsToNs(1700000000);
  for (int i = 0; i < 2; ++i) {
    const TimeNs t = start + i * millisecondsToNs(50);
    const Rigid3d pose(Eigen::Quaterniond(1.0, 0.0, 0.0, 0.1 * i).normalized(),
                       Eigen::Vector3d(0.2 * i, 0.0, 0.0));
    records.push_back(PoseSample{t, "odometry", pose});
    records.push_back(PoseSample{t + 1000, "ground_truth", pose});
    for (const char* sensor : {"fisheye", "cam03"}) {
      ImageFrame frame;
      frame.t = t + 2000;
      frame.sensor = sensor;
      frame.encoded = tinyPng(40 * (i + 1));
      frame.extension = ".png";
      records.push_back(frame);
    }
    MarkerObservation marker;
    marker.t = t + 3000;
    marker.camera = "cam03";
    marker.marker_id = 3;
    marker.camera_from_marker =
        Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * i, 0.0, 2.5));
    marker.information = Eigen::Matrix<double, 6, 6>::Identity() * 100.0;
    marker.corners_px = {{300.0, 160.0}, {340.0, 160.0}, {340.0, 200.0}, {300.0, 200.0}};
    marker.corner_sigma_px = 0.2;
    records.push_back(marker);
    BlobObservation blobs;
    blobs.t = t + 4000;
    blobs.camera = "fisheye";
    blobs.image_width = 640;
    blobs.image_height = 360;
    blobs.blobs = {{320.0 + i, 180.0, 9.0, 0.75}};
    records.push_back(blobs);
  }
  return records;
}

/// Writes the sample dataset as `rawlog` (+ its manifest and images).
inline void writeSampleRawlog(const std::filesystem::path& rawlog, bool calibrated = true) {
  DatasetWriteOptions options;
  options.overwrite = true;
  auto writer =
      DatasetWriter::create(rawlog, DatasetKind::kRawlog, fuzzManifest(calibrated), options);
  for (const Record& record : fuzzRecords()) writer->write(record);
  writer->finish();
}

/// The topics of the seed bag and how the rosbag target imports them.
inline RosbagImportOptions fuzzBagOptions() {
  RosbagImportOptions options;
  options.topics = {
      {"/fisheye/image_raw", "", "fisheye", true, "", "", ""},
      {"/fisheye/camera_info", "", "fisheye", true, "", "", ""},
      {"/cam03/image/compressed", "cam03", "env_camera", true, "", "", ""},
      {"/cam03/camera_info", "cam03", "env_camera", true, "", "", ""},
      {"/odom", "", "odometry", false, "", "", ""},
      {"/ground_truth/pose", "", "ground_truth", true, "", "", ""},
  };
  options.on_warning = [](const std::string&) {};
  return options;
}

/// The mapping of the ROS 2 fixtures' topics (tests/data/ros2), every type lookboth reads.
inline RosbagImportOptions fuzzRos2Options() {
  RosbagImportOptions options;
  for (const char* mapping :
       {"/fisheye/image_raw=fisheye:fisheye", "/env_cam/image/compressed=env_cam:env_camera",
        "/odom=odometry:odometry", "/ground_truth/pose=ground_truth:ground_truth",
        "/initialpose=initial:odometry", "/tf=tf_base:odometry:child=base_link"}) {
    options.topics.push_back(parseTopicMapping(mapping));
  }
  options.marker = MarkerSpec{"DICT_4X4_50", 0, 0.2};
  options.on_warning = [](const std::string&) {};
  return options;
}

/// The folder dataset of tests/data whose text files the folder target rewrites.
inline std::filesystem::path folderSample() {
  return std::filesystem::path(LOOKBOTH_TEST_DATA_DIR) / "datasets" / "folder_small";
}

/// The text files (CSV, TUM, YAML, calibrations) of a folder dataset,
/// relative to it, sorted: the first byte of a folder input picks one.
inline std::vector<std::filesystem::path> folderTextFiles(const std::filesystem::path& folder) {
  static const std::vector<std::string> kExtensions = {".csv", ".tum", ".yaml",
                                                       ".yml", ".txt", ".xml"};
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(folder)) {
    const std::string extension = entry.path().extension().string();
    if (entry.is_regular_file() &&
        std::find(kExtensions.begin(), kExtensions.end(), extension) != kExtensions.end()) {
      files.push_back(entry.path().lexically_relative(folder));
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace lookboth::fuzz
