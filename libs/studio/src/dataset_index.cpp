#include "lookboth/studio/dataset_index.h"

#include <algorithm>

#include "lookboth/core/error.h"

namespace lookboth::studio {
namespace {

template <typename T>
void sortByTime(std::vector<T>& items) {
  std::stable_sort(items.begin(), items.end(), [](const T& a, const T& b) { return a.t < b.t; });
}

}  // namespace

DatasetIndex DatasetIndex::build(const std::filesystem::path& dataset,
                                 const ProgressReporter& progress) {
  DatasetIndex index;
  DatasetReadOptions options;
  options.check_images = false;  // the views report a missing image when they show it
  auto reader = DatasetReader::open(dataset, options);
  index.path_ = dataset;
  index.manifest_ = reader->manifest();
  const CameraSensor* fisheye = index.manifest_.fisheye();
  const std::string fisheye_label = fisheye ? fisheye->label : std::string();
  const std::int64_t expected = reader->expectedCount();

  std::map<std::string, std::vector<StampedPose>> poses;
  std::int64_t count = 0;
  while (auto record = reader->next()) {
    ++index.record_counts_[recordKindName(*record)];
    if (auto* frame = std::get_if<ImageFrame>(&*record)) {
      FrameRef ref{frame->t, std::move(*frame)};
      if (ref.image.sensor == fisheye_label) {
        index.fisheye_frames_.push_back(std::move(ref));
      } else {
        index.camera_frames_[ref.image.sensor].push_back(std::move(ref));
      }
    } else if (auto* marker = std::get_if<MarkerObservation>(&*record)) {
      if (marker->marker_id == index.manifest_.marker.id) {
        index.markers_[marker->camera].push_back(*marker);
      } else {
        index.fixed_markers_.push_back(*marker);
      }
    } else if (auto* blobs = std::get_if<BlobObservation>(&*record)) {
      index.blobs_.push_back(std::move(*blobs));
    } else if (auto* pose = std::get_if<PoseSample>(&*record)) {
      poses[pose->label].push_back(StampedPose{pose->t, pose->world_from_body});
    }
    if (++count % 256 == 0) {
      progress.checkStop();
      progress.report("open", count, std::max<std::int64_t>(expected, 0));
    }
  }
  progress.report("open", count, count);
  index.issues_ = reader->issues();

  sortByTime(index.fisheye_frames_);
  for (auto& [label, frames] : index.camera_frames_) sortByTime(frames);
  for (auto& [label, markers] : index.markers_) sortByTime(markers);
  sortByTime(index.blobs_);
  for (auto& [label, samples] : poses) {
    sortByTime(samples);
    // Readers already refuse duplicated stamps; keep the first of any that remain.
    samples.erase(
        std::unique(samples.begin(), samples.end(),
                    [](const StampedPose& a, const StampedPose& b) { return a.t == b.t; }),
        samples.end());
    index.trajectories_.emplace(label, Trajectory(std::move(samples)));
  }
  return index;
}

const std::vector<FrameRef>& DatasetIndex::cameraFrames(const std::string& label) const {
  static const std::vector<FrameRef> kNone;
  const auto it = camera_frames_.find(label);
  return it == camera_frames_.end() ? kNone : it->second;
}

const std::vector<MarkerObservation>& DatasetIndex::markers(const std::string& label) const {
  static const std::vector<MarkerObservation> kNone;
  const auto it = markers_.find(label);
  return it == markers_.end() ? kNone : it->second;
}

const BlobObservation* DatasetIndex::blobsAt(TimeNs t) const {
  const auto it = std::lower_bound(blobs_.begin(), blobs_.end(), t,
                                   [](const BlobObservation& b, TimeNs q) { return b.t < q; });
  return it != blobs_.end() && it->t == t ? &*it : nullptr;
}

const Trajectory* DatasetIndex::trajectory(const std::string& label) const {
  const auto it = trajectories_.find(label);
  return it == trajectories_.end() ? nullptr : &it->second;
}

std::vector<CameraSummary> DatasetIndex::cameraSummaries() const {
  std::vector<CameraSummary> rows;
  for (const CameraSensor& sensor : manifest_.cameras) {
    if (sensor.role != SensorRole::kEnvCamera) continue;
    CameraSummary row;
    row.label = sensor.label;
    row.has_calibration = sensor.camera.has_value();
    row.frames = static_cast<std::int64_t>(cameraFrames(sensor.label).size());
    const auto& observations = markers(sensor.label);
    row.detections = static_cast<std::int64_t>(observations.size());
    if (!observations.empty()) {
      row.first_detection = observations.front().t;
      row.last_detection = observations.back().t;
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace lookboth::studio

#include <opencv2/imgcodecs.hpp>

#include "lookboth/dataset/frame_decoder.h"

namespace lookboth::studio {

cv::Mat decodeFrame(const ImageFrame& frame) {
  if (!frame.encoded && !isVideoFrame(frame) && !std::filesystem::exists(frame.image_file))
    throw Error(frame.image_file.string() + ": image file missing (frame of '" + frame.sensor +
                "')");
  // The window asks for frames of several cameras in turn: one decoder
  // keeps their videos open.
  thread_local FrameDecoder decoder;
  cv::Mat image = decoder.decode(frame, FrameColour::kAsStored);
  if (image.empty())
    throw Error(frameName(frame) + ": not a readable image (frame of '" + frame.sensor + "')");
  if (image.depth() != CV_8U)
    image.convertTo(image, CV_8U, image.depth() == CV_16U ? 1.0 / 256 : 1.0);
  return image;
}

}  // namespace lookboth::studio
