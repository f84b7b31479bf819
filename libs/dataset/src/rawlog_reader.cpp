// Streams records out of an MRPT observations-only rawlog (also accepts
// sensory-frame rawlogs from other MRPT tools: their observations are read,
// their actions skipped).
#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/obs/CActionCollection.h>
#include <mrpt/obs/CObservation6DFeatures.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/obs/CObservationRobotPose.h>
#include <mrpt/obs/CSensoryFrame.h>
#include <mrpt/serialization/CArchive.h>

#include <deque>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <tuple>

#include "internal.h"
#include "lookboth/core/error.h"
#include "lookboth/geometry/pose_conversions.h"
#include "lookboth/obs/CObservationMarkerCorners.h"

namespace lookboth::internal {
namespace {

namespace fs = std::filesystem;

class RawlogReader : public DatasetReader {
 public:
  RawlogReader(const fs::path& rawlog, const DatasetReadOptions& options)
      : DatasetReader(rawlog, DatasetKind::kRawlog, options),
        images_dir_(imagesDirectoryFor(rawlog)) {
    registerLookbothObservations();
    const fs::path manifest_path = manifestPathFor(rawlog);
    if (!fs::exists(manifest_path)) {
      throw Error({rawlog.string(), 0, "", ""},
                  "its manifest '" + manifest_path.string() +
                      "' is missing (a lookboth dataset is <name>.rawlog + <name>.yaml)");
    }
    manifest_ = loadManifest(manifest_path);
    if (manifest_.name.empty()) manifest_.name = rawlog.stem().string();
    if (!stream_.open(rawlog.string())) {
      throw Error({rawlog.string(), 0, "", ""}, "cannot open for reading");
    }
    archive_ =
        std::make_unique<mrpt::serialization::CArchiveStreamBase<mrpt::io::CFileGZInputStream>>(
            stream_);
  }

  std::int64_t expectedCount() const override { return manifest_.rawlog_entries; }

  std::optional<Record> next() override {
    // The marker poses of the last entry read may still get their corners
    // from the next entries: read on before handing them out.
    while (!at_end_ && pending_.size() <= unsettled_) readEntry();
    if (pending_.empty()) return std::nullopt;
    Record record = std::move(pending_.front());
    pending_.pop_front();
    return record;
  }

 private:
  std::string where() const { return path_.string() + ": entry " + std::to_string(entry_); }

  void readEntry() {
    const uint64_t position = stream_.getPosition();
    mrpt::serialization::CSerializable::Ptr object;
    try {
      object = archive_->ReadObject();
    } catch (const mrpt::serialization::CExceptionEOF& e) {
      if (stream_.getPosition() != position) {
        at_end_ = true;
        throw Error(where() + ": the file is truncated inside this entry (" +
                    std::to_string(entry_) + " complete entries were read)");
      }
      at_end_ = true;
      if (manifest_.rawlog_entries >= 0 && entry_ < manifest_.rawlog_entries) {
        throw Error(path_.string() + ": truncated: " + std::to_string(entry_) + " of the " +
                    std::to_string(manifest_.rawlog_entries) +
                    " entries listed in the manifest were found");
      }
      return;
    } catch (const std::exception& e) {
      at_end_ = true;
      std::string message = e.what();
      if (message.find("not registered") != std::string::npos ||
          message.find("Unknown class") != std::string::npos ||
          message.find("registered") != std::string::npos) {
        throw Error(where() +
                    ": holds an object of a class that is not registered (an MRPT plugin "
                    "or a newer lookboth may be needed): " +
                    firstLine(message));
      }
      throw Error(where() + ": cannot be read (corrupt or truncated file): " + firstLine(message));
    }
    ++entry_;
    if (auto frame = std::dynamic_pointer_cast<mrpt::obs::CSensoryFrame>(object)) {
      for (const auto& obs : *frame) convert(obs);
    } else if (auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservation>(object)) {
      convert(obs);
    } else if (std::dynamic_pointer_cast<mrpt::obs::CActionCollection>(object)) {
      skippedOnce("actions (odometry increments of a sensory-frame rawlog)");
    } else {
      skippedOnce(std::string("objects of class ") + object->GetRuntimeClass()->className);
    }
  }

  static std::string firstLine(const std::string& text) {
    const size_t newline = text.find('\n');
    return newline == std::string::npos ? text : text.substr(0, newline);
  }

  void skippedOnce(const std::string& what) {
    if (skipped_.insert(what).second)
      reportIssue(where(), what + " are not used by lookboth; skipped");
  }

  // Drops duplicates and reports out-of-order stamps per (kind, label) stream.
  bool acceptTime(const Record& record) {
    const std::string key = std::string(recordKindName(record)) + "/" + recordLabel(record);
    const TimeNs t = recordTime(record);
    const auto it = last_time_.find(key);
    if (it != last_time_.end()) {
      if (t == it->second) {
        reportIssue(where(), std::string(recordKindName(record)) + " of '" + recordLabel(record) +
                                 "' repeats timestamp " + formatSeconds(t) + " s; dropped");
        return false;
      }
      if (t < it->second) {
        reportIssue(where(), std::string(recordKindName(record)) + " of '" + recordLabel(record) +
                                 "' at " + formatSeconds(t) +
                                 " s is earlier than the previous one (" +
                                 formatSeconds(it->second) + " s)");
      }
    }
    last_time_[key] = t;
    return true;
  }

  bool push(Record record) {
    if (!acceptTime(record)) return false;
    pending_.push_back(std::move(record));
    return true;
  }

  TimeNs timeOf(const mrpt::obs::CObservation& obs) {
    try {
      return fromMrptTime(obs.timestamp);
    } catch (const Error& e) {
      throw Error(where() + " ('" + obs.sensorLabel + "'): " + e.what());
    }
  }

  /// Gives the corners to the marker pose of the entry just before (same
  /// label, stamp and id; doc/formats.md).
  void attachCorners(const CObservationMarkerCorners& corners) {
    const TimeNs t = timeOf(corners);
    for (const auto& [label, time, id, kept] : last_features_) {
      if (label != corners.sensorLabel || time != t || id != corners.marker_id) continue;
      if (!kept) return;  // its pose was dropped (reported): so are its corners
      for (auto it = pending_.rbegin(); it != pending_.rend(); ++it) {
        auto* marker = std::get_if<MarkerObservation>(&*it);
        if (!marker || marker->camera != label || marker->t != t || marker->marker_id != id ||
            !marker->corners_px.empty()) {
          continue;
        }
        for (const CornerPixel& c : corners.corners) marker->corners_px.emplace_back(c.u, c.v);
        marker->corner_sigma_px = corners.corner_sigma_px;
        return;
      }
    }
    reportIssue(where(), "marker corners of '" + corners.sensorLabel + "' (marker " +
                             std::to_string(corners.marker_id) + ") at " + formatSeconds(t) +
                             " s do not follow their marker pose (a CObservation6DFeatures of "
                             "the same label, stamp and id); skipped");
  }

  void convert(const mrpt::obs::CObservation::Ptr& obs) {
    if (auto corners = std::dynamic_pointer_cast<CObservationMarkerCorners>(obs)) {
      attachCorners(*corners);
      return;
    }
    last_features_.clear();
    unsettled_ = 0;
    if (auto image = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(obs)) {
      ImageFrame frame;
      frame.t = timeOf(*image);
      frame.sensor = image->sensorLabel;
      if (image->image.isExternallyStored()) {
        frame.image_file = images_dir_ / image->image.getExternalStorageFile();
        if (options_.check_images && !fs::exists(frame.image_file)) {
          reportIssue(where(), "image '" + frame.image_file.string() + "' of '" + frame.sensor +
                                   "' is missing; frame skipped");
          return;
        }
      } else {
        // Embedded in the rawlog (other tools do this): re-encode losslessly.
        std::vector<uchar> bytes;
        cv::imencode(".png", image->image.asCvMatRef(), bytes);
        frame.encoded =
            std::make_shared<const std::vector<std::uint8_t>>(bytes.begin(), bytes.end());
        frame.extension = ".png";
      }
      push(std::move(frame));
    } else if (auto features = std::dynamic_pointer_cast<mrpt::obs::CObservation6DFeatures>(obs)) {
      for (const auto& m : features->sensedFeatures) {
        MarkerObservation marker;
        marker.t = timeOf(*features);
        marker.camera = features->sensorLabel;
        marker.marker_id = m.id;
        marker.camera_from_marker = fromMrptPose(m.pose);
        for (int i = 0; i < 6; ++i) {
          for (int j = 0; j < 6; ++j) marker.information(i, j) = m.inf_matrix(i, j);
        }
        last_features_.emplace_back(marker.camera, marker.t, marker.marker_id, false);
        std::get<3>(last_features_.back()) = push(std::move(marker));
        unsettled_ += std::get<3>(last_features_.back()) ? 1 : 0;
      }
    } else if (auto blobs = std::dynamic_pointer_cast<CObservationBlobs>(obs)) {
      BlobObservation record;
      record.t = timeOf(*blobs);
      record.camera = blobs->sensorLabel;
      record.image_width = blobs->image_width;
      record.image_height = blobs->image_height;
      record.blobs = blobs->blobs;
      push(std::move(record));
    } else if (auto pose = std::dynamic_pointer_cast<mrpt::obs::CObservationRobotPose>(obs)) {
      PoseSample sample;
      sample.t = timeOf(*pose);
      sample.label = pose->sensorLabel;
      sample.world_from_body = fromMrptPose(pose->pose.mean);
      push(std::move(sample));
    } else {
      skippedOnce(std::string("observations of class ") + obs->GetRuntimeClass()->className);
    }
  }

  fs::path images_dir_;
  mrpt::io::CFileGZInputStream stream_;
  std::unique_ptr<mrpt::serialization::CArchiveStreamBase<mrpt::io::CFileGZInputStream>> archive_;
  std::deque<Record> pending_;
  std::map<std::string, TimeNs> last_time_;
  std::set<std::string> skipped_;
  std::int64_t entry_ = 0;
  bool at_end_ = false;
  /// How many records at the back of pending_ are marker poses that the next
  /// entries may still give corners to (those of the last 6DFeatures, while
  /// only corners follow it).
  size_t unsettled_ = 0;
  /// (label, stamp, id, kept) of the marker poses of the last 6DFeatures.
  std::vector<std::tuple<std::string, TimeNs, int, bool>> last_features_;
};

}  // namespace

std::unique_ptr<DatasetReader> openRawlogReader(const fs::path& rawlog,
                                                const DatasetReadOptions& options) {
  return std::make_unique<RawlogReader>(rawlog, options);
}

}  // namespace lookboth::internal
