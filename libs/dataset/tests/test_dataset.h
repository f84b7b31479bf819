// A small synthetic dataset shared by the dataset tests.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/geometry/lie.h"

namespace lookboth::testing {

inline Manifest sampleManifest() {
  Manifest m;
  m.name = "sample";
  m.marker = {"DICT_4X4_50", 7, 0.2};
  const std::string cams = std::string(LOOKBOTH_SHARE_DIR) + "/cameras/";
  m.cameras.push_back(
      {"fisheye", SensorRole::kFisheye, loadCamera(cams + "fisheye_calib_results.txt")});
  m.cameras.push_back(
      {"cam00", SensorRole::kEnvCamera, loadCamera(cams + "ceiling_camera_ros.yaml")});
  m.cameras.push_back(
      {"cam01", SensorRole::kEnvCamera, loadCamera(cams + "fisheye_double_sphere.yaml")});
  m.trajectories.push_back({"odometry", false, "monocular VO"});
  m.trajectories.push_back({"ground_truth", true, "simulation"});
  m.ground_truth.world_from_camera["cam00"] =
      Rigid3d(Eigen::Quaterniond(0.0, 1.0, 0.0, 0.0), Eigen::Vector3d(2.0, 3.0, 3.5));
  m.ground_truth.world_from_camera["cam01"] =
      Rigid3d(Eigen::Quaterniond(0.0, 0.6, 0.8, 0.0), Eigen::Vector3d(-1.25, 0.5, 3.75));
  m.ground_truth.fisheye_from_marker =
      Rigid3d(Eigen::Quaterniond(0.0, 1.0, 0.0, 0.0), Eigen::Vector3d(-0.1, 0.0, -0.35));
  m.ground_truth.clock_offset["cam00"] = 1'200'000;
  m.ground_truth.clock_offset["cam01"] = -700'000;
  m.ground_truth.hidden_from_fisheye["cam01"] = {{1'000'000'000, 1'100'000'000},
                                                 {1'500'000'000, 1'500'000'000}};
  return m;
}

inline std::shared_ptr<const std::vector<std::uint8_t>> pngBytes(int seed) {
  cv::Mat image(24, 32, CV_8UC3);
  cv::randu(image, cv::Scalar::all(seed), cv::Scalar::all(255));
  std::vector<uchar> bytes;
  cv::imencode(".png", image, bytes);
  return std::make_shared<const std::vector<std::uint8_t>>(bytes.begin(), bytes.end());
}

/// Records in time order: frames of the fisheye and cam00, markers, blobs, two trajectories.
inline std::vector<Record> sampleRecords() {
  std::vector<Record> records;
  const TimeNs t0 = secondsToNs(1700000000);
  for (int i = 0; i < 10; ++i) {
    const TimeNs t = t0 + i * millisecondsToNs(100);
    Eigen::Matrix<double, 6, 1> xi;
    xi << 0.1 * i, 0.02 * i, 0.0, 0.0, 0.0, 0.05 * i;
    const Rigid3d pose = se3Exp(xi);
    records.push_back(PoseSample{t, "odometry", pose});
    records.push_back(PoseSample{t + 300, "ground_truth", pose});
    ImageFrame frame;
    frame.t = t + 1000;
    frame.sensor = i % 2 ? "cam00" : "fisheye";
    frame.encoded = pngBytes(i);
    frame.extension = ".png";
    records.push_back(frame);
    MarkerObservation marker;
    marker.t = t + 2000;
    marker.camera = "cam00";
    marker.marker_id = 7;
    marker.camera_from_marker = Rigid3d(Eigen::Quaterniond(0.9, 0.1, 0.2, 0.3).normalized(),
                                        Eigen::Vector3d(0.01 * i, -0.2, 3.1));
    marker.information = Eigen::Matrix<double, 6, 6>::Identity() * (1e4 + i);
    marker.information(0, 5) = marker.information(5, 0) = 3.5;
    records.push_back(marker);
    BlobObservation blobs;
    blobs.t = t + 3000;
    blobs.camera = "fisheye";
    blobs.image_width = 1920;
    blobs.image_height = 1080;
    blobs.blobs = {{100.5 + i, 200.25, 12.0, 0.5}, {900.0, 33.0 + i, 8.5, 0.125}};
    records.push_back(blobs);
  }
  return records;
}

/// The records with the marker's corners on every other marker observation
/// (the others keep none, as old datasets), some with a corner noise, values
/// that only a lossless round trip keeps.
inline std::vector<Record> withCorners(std::vector<Record> records) {
  int n = 0;
  for (Record& record : records) {
    auto* marker = std::get_if<MarkerObservation>(&record);
    if (!marker || n++ % 2 == 0) continue;
    const double u = 300.1 + n / 3.0, v = 200.7 - n / 7.0;
    marker->corners_px = {{u, v}, {u + 40.03125, v + 0.1}, {u + 39.9, v + 41.0 / 3.0}, {u, v + 40}};
    marker->corner_sigma_px = n % 4 == 0 ? 0.0 : 0.05 + 1.0 / (n + 7);
  }
  return records;
}

/// Field-by-field equality of records (image bytes compared by content).
::testing::AssertionResult sameRecord(const Record& a, const Record& b);

}  // namespace lookboth::testing
