// Writes a dataset as an MRPT observations-only rawlog + manifest + images folder.
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/obs/CObservation6DFeatures.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationRobotPose.h>
#include <mrpt/serialization/CArchive.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <set>

#include "internal.h"
#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/dataset/frame_decoder.h"
#include "lookboth/geometry/pose_conversions.h"
#include "lookboth/obs/CObservationMarkerCorners.h"

namespace lookboth::internal {
namespace {

namespace fs = std::filesystem;

class RawlogWriter : public DatasetWriter {
 public:
  RawlogWriter(const fs::path& rawlog, const Manifest& manifest, const DatasetWriteOptions& options)
      : DatasetWriter(manifest),
        rawlog_(rawlog),
        images_dir_(imagesDirectoryFor(rawlog)),
        manifest_path_(manifestPathFor(rawlog)),
        overwrite_(options.overwrite),
        link_images_(options.link_images),
        temporary_rawlog_(temporarySibling(rawlog)),
        temporary_images_(temporarySibling(images_dir_)) {
    checkOutputPath(rawlog_, overwrite_);
    checkOutputPath(manifest_path_, overwrite_);
    checkOutputPath(images_dir_, overwrite_);
    if (!stream_.open(temporary_rawlog_.string())) {
      throw Error({rawlog_.string(), 0, "", ""}, "cannot open a temporary file for writing");
    }
    archive_ =
        std::make_unique<mrpt::serialization::CArchiveStreamBase<mrpt::io::CFileGZOutputStream>>(
            stream_);
    for (const CameraSensor& sensor : manifest.cameras) {
      if (!sensor.camera) continue;
      try {
        mrpt_cameras_[sensor.label] = toMrptCamera(*sensor.camera);
      } catch (const Error&) {
        // Not representable in TCamera (Scaramuzza, double sphere): the
        // manifest holds the model; cameraParams stays default.
      }
    }
  }

  ~RawlogWriter() override {
    if (finished_) return;
    archive_.reset();
    stream_.close();
    std::error_code ignored;
    fs::remove(temporary_rawlog_, ignored);
    fs::remove_all(temporary_images_, ignored);
  }

  void write(const Record& record) override {
    std::visit([this](const auto& r) { writeRecord(r); }, record);
    ++records_written_;
  }

  void finish(const Manifest& manifest) override {
    archive_.reset();
    stream_.close();
    Manifest final_manifest = manifest;
    final_manifest.rawlog_entries = entries_;
    if (final_manifest.name.empty()) final_manifest.name = rawlog_.stem().string();
    if (const std::string why = final_manifest.check(); !why.empty()) {
      throw Error({manifest_path_.string(), 0, "", ""}, "inconsistent manifest: " + why);
    }
    // Images first, then the rawlog, the manifest last: a manifest beside a
    // rawlog means the dataset is complete.
    if (images_written_) {
      moveIntoPlace(temporary_images_, images_dir_, overwrite_);
    } else if (overwrite_ && fs::exists(images_dir_)) {
      fs::remove_all(images_dir_);
    }
    moveIntoPlace(temporary_rawlog_, rawlog_, overwrite_);
    saveManifest(final_manifest, manifest_path_);
    finished_ = true;
  }

 private:
  void writeObservation(const mrpt::obs::CObservation& obs) {
    errno = 0;
    try {
      (*archive_) << obs;
    } catch (const std::exception&) {
      throw writeError();
    }
    ++entries_;
  }

  /// A failed write is the environment's (a full disk, a read-only or
  /// removed folder), not a bug: say so plainly, not with MRPT's stack dump.
  Error writeError() const {
    const int cause = errno;
    return Error({rawlog_.string(), 0, "", ""},
                 std::string("cannot write the rawlog") +
                     (cause != 0 ? std::string(": ") + std::strerror(cause) : std::string()) +
                     " (a full disk or a read-only folder?); nothing was written");
  }

  void writeRecord(const ImageFrame& frame) {
    if (!frame.encoded && isVideoFrame(frame)) {
      writeRecord(extractedFrame(frame));
      return;
    }
    std::string extension = frame.encoded ? frame.extension : frame.image_file.extension().string();
    if (extension.empty()) extension = ".png";
    if (extension.front() != '.') extension.insert(0, ".");
    const std::string name = frame.sensor + "_" + std::to_string(frame.t) + extension;
    if (!images_written_) {
      fs::create_directories(temporary_images_);
      images_written_ = true;
    }
    const fs::path target = temporary_images_ / name;
    if (fs::exists(target)) {
      throw Error({rawlog_.string(), 0, "", frame.sensor},
                  "two frames of the same camera at t=" + std::to_string(frame.t) + " ns");
    }
    if (frame.encoded) {
      std::ofstream out(target, std::ios::binary);
      out.write(reinterpret_cast<const char*>(frame.encoded->data()),
                static_cast<std::streamsize>(frame.encoded->size()));
      if (!out) throw Error({target.string(), 0, "", ""}, "cannot write image");
    } else {
      placeImageFile(frame.image_file, target, link_images_, frame.sensor);
    }
    mrpt::obs::CObservationImage obs;
    obs.sensorLabel = frame.sensor;
    obs.timestamp = toMrptTime(frame.t);
    if (const auto it = mrpt_cameras_.find(frame.sensor); it != mrpt_cameras_.end()) {
      obs.cameraParams = it->second;
    }
    obs.image.setExternalStorage(name);
    writeObservation(obs);
  }

  /// A rawlog holds one image per frame (what MRPT's tools read): a video
  /// frame is decoded and stored as PNG, losslessly from the decoded pixels.
  ImageFrame extractedFrame(const ImageFrame& frame) {
    const cv::Mat image = video_decoder_.decode(frame, FrameColour::kAsStored);
    if (image.empty()) {
      throw Error({frame.video_file.string(), 0, "", frame.sensor},
                  "cannot decode " + frameName(frame) + " for the rawlog's images");
    }
    auto bytes = std::make_shared<std::vector<std::uint8_t>>();
    cv::imencode(".png", image, *bytes);
    ImageFrame extracted;
    extracted.t = frame.t;
    extracted.sensor = frame.sensor;
    extracted.encoded = std::move(bytes);
    extracted.extension = ".png";
    return extracted;
  }

  void writeRecord(const MarkerObservation& marker) {
    if (!marker.corners_px.empty() && marker.corners_px.size() != 4) {
      throw Error({rawlog_.string(), 0, "", marker.camera},
                  "marker observation at " + std::to_string(marker.t) + " ns has " +
                      std::to_string(marker.corners_px.size()) + " corners (expected 0 or 4)");
    }
    mrpt::obs::CObservation6DFeatures obs;
    obs.sensorLabel = marker.camera;
    obs.timestamp = toMrptTime(marker.t);
    mrpt::obs::CObservation6DFeatures::TMeasurement m;
    m.pose = toMrptPose(marker.camera_from_marker);
    m.id = marker.marker_id;
    for (int i = 0; i < 6; ++i) {
      for (int j = 0; j < 6; ++j) m.inf_matrix(i, j) = marker.information(i, j);
    }
    obs.sensedFeatures.push_back(m);
    writeObservation(obs);
    if (marker.corners_px.empty()) return;
    // Right after its pose, same label, stamp and id: the reader pairs them.
    CObservationMarkerCorners corners;
    corners.sensorLabel = marker.camera;
    corners.timestamp = obs.timestamp;
    corners.marker_id = marker.marker_id;
    for (size_t k = 0; k < 4; ++k) {
      corners.corners[k] = {marker.corners_px[k].x(), marker.corners_px[k].y()};
    }
    corners.corner_sigma_px = marker.corner_sigma_px;
    writeObservation(corners);
  }

  void writeRecord(const BlobObservation& blobs) {
    CObservationBlobs obs;
    obs.sensorLabel = blobs.camera;
    obs.timestamp = toMrptTime(blobs.t);
    obs.image_width = blobs.image_width;
    obs.image_height = blobs.image_height;
    obs.blobs = blobs.blobs;
    writeObservation(obs);
  }

  void writeRecord(const PoseSample& sample) {
    mrpt::obs::CObservationRobotPose obs;
    obs.sensorLabel = sample.label;
    obs.timestamp = toMrptTime(sample.t);
    obs.pose.mean = toMrptPose(sample.world_from_body);
    obs.pose.cov.setZero();
    writeObservation(obs);
  }

  fs::path rawlog_, images_dir_, manifest_path_;
  bool overwrite_;
  bool link_images_;
  fs::path temporary_rawlog_, temporary_images_;
  mrpt::io::CFileGZOutputStream stream_;
  std::unique_ptr<mrpt::serialization::CArchiveStreamBase<mrpt::io::CFileGZOutputStream>> archive_;
  std::map<std::string, mrpt::img::TCamera> mrpt_cameras_;
  bool images_written_ = false;
  FrameDecoder video_decoder_;  ///< For video frames, stored as PNG.
  bool finished_ = false;
  std::int64_t entries_ = 0;
};

}  // namespace

std::unique_ptr<DatasetWriter> createRawlogWriter(const fs::path& rawlog, const Manifest& manifest,
                                                  const DatasetWriteOptions& options) {
  return std::make_unique<RawlogWriter>(rawlog, manifest, options);
}

}  // namespace lookboth::internal
