// Writes a synthetic folder dataset of N fisheye frames (with one marker
// observation, one blob observation and two trajectory samples per frame)
// for the conversion benchmark (scripts/bench_convert.sh).
//   lookboth-bench-make-stream <frames> <out_folder> [width height]
#include <cstdlib>
#include <iostream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/core/paths.h"
#include "lookboth/dataset/dataset_io.h"

int main(int argc, char** argv) {
  using namespace lookboth;
  if (argc != 3 && argc != 5) {
    std::cerr << "usage: " << argv[0] << " <frames> <out_folder> [width height]\n";
    return 2;
  }
  const int frames = std::atoi(argv[1]);
  const int width = argc == 5 ? std::atoi(argv[3]) : 160;
  const int height = argc == 5 ? std::atoi(argv[4]) : 120;
  try {
    Manifest manifest;
    manifest.marker = {"DICT_4X4_50", 3, 0.2};
    const auto cams = shareDirectory() / "cameras";
    manifest.cameras.push_back(
        {"fisheye", SensorRole::kFisheye, loadCamera(cams / "fisheye_calib_results.txt")});
    manifest.cameras.push_back(
        {"cam00", SensorRole::kEnvCamera, loadCamera(cams / "ceiling_camera_ros.yaml")});
    manifest.trajectories.push_back({"odometry", false, "synthetic"});
    manifest.trajectories.push_back({"ground_truth", true, "synthetic"});
    auto writer = DatasetWriter::create(argv[2], DatasetKind::kFolder, manifest);
    // A few distinct images, reused: the benchmark measures conversion, not PNG encoding here.
    std::vector<std::shared_ptr<const std::vector<std::uint8_t>>> images;
    for (int i = 0; i < 8; ++i) {
      cv::Mat image(height, width, CV_8UC1);
      cv::randu(image, cv::Scalar(0), cv::Scalar(255));
      std::vector<uchar> bytes;
      cv::imencode(".png", image, bytes);
      images.push_back(
          std::make_shared<const std::vector<std::uint8_t>>(bytes.begin(), bytes.end()));
    }
    const TimeNs t0 = secondsToNs(1700000000);
    for (int i = 0; i < frames; ++i) {
      const TimeNs t = t0 + i * 33'333'300LL;
      const Rigid3d pose(Eigen::Quaterniond(Eigen::AngleAxisd(0.001 * i, Eigen::Vector3d::UnitZ())),
                         Eigen::Vector3d(0.03 * i, 0.0, 0.0));
      writer->write(PoseSample{t, "odometry", pose});
      writer->write(PoseSample{t + 100, "ground_truth", pose});
      ImageFrame frame;
      frame.t = t + 200;
      frame.sensor = "fisheye";
      frame.encoded = images[i % images.size()];
      frame.extension = ".png";
      writer->write(frame);
      MarkerObservation marker;
      marker.t = t + 300;
      marker.camera = "cam00";
      marker.marker_id = 3;
      marker.camera_from_marker =
          Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1, 0.2, 3.0));
      writer->write(marker);
      BlobObservation blobs;
      blobs.t = t + 400;
      blobs.camera = "fisheye";
      blobs.blobs = {{100.0 + i % 50, 200.0, 12.0, 0.5}};
      writer->write(blobs);
    }
    writer->finish();
    std::cout << "wrote " << argv[2] << ": " << frames << " frames of " << width << "x" << height
              << "\n";
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
