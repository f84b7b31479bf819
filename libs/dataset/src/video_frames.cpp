#include "video_frames.h"

#include "csv.h"
#include "lookboth/core/error.h"
#include "lookboth/dataset/video.h"

namespace lookboth::internal {

namespace fs = std::filesystem;

VideoFrameSource::VideoFrameSource(fs::path video, std::string label, VideoTiming timing,
                                   VideoIssueSink issue, VideoIssueSink note)
    : video_(fs::absolute(video).lexically_normal()),
      label_(std::move(label)),
      timing_(std::move(timing)),
      issue_(std::move(issue)),
      note_(std::move(note)) {}

std::optional<ImageFrame> VideoFrameSource::next() {
  if (!loaded_) load();
  if (next_ >= frames_.size()) return std::nullopt;
  ImageFrame frame;
  frame.t = frames_[next_].first;
  frame.sensor = label_;
  frame.video_file = video_;
  frame.video_frame = frames_[next_].second;
  ++next_;
  return frame;
}

void VideoFrameSource::load() {
  loaded_ = true;
  const bool by_container = timing_.sidecar.empty();
  if (by_container && !timing_.start) {
    throw Error({video_.string(), 0, "", label_},
                "the frames' times are unknown: " + timing_.how_to_time);
  }
  VideoProbe probe = probeVideo(video_, by_container);
  // A sidecar's frame indices are checked against the frames the file has:
  // counted when the header does not say (MKV, raw streams).
  if (!by_container && probe.frame_count < 0) probe = probeVideo(video_, true);
  size_ = {probe.width, probe.height};
  if (by_container) {
    if (probe.frame_offsets_ns.empty() && probe.frame_count > 0) {
      throw Error({video_.string(), 0, "", label_},
                  "the container has no frame timestamps (a raw " + probe.codec +
                      " stream?): time its frames with a sidecar CSV (timestamp_ns per frame)");
    }
    loadContainerTimes(probe.frame_offsets_ns);
  } else {
    loadSidecar(probe.frame_count);
  }
  noteGaps();
}

void VideoFrameSource::loadSidecar(std::int64_t frame_count) {
  CsvReader csv(timing_.sidecar, {"timestamp_ns"});
  const bool indexed = csv.hasColumn("frame");
  std::int64_t row = 0;
  while (csv.next()) {
    const TimeNs t = csv.integer("timestamp_ns");
    const std::int64_t frame = indexed ? csv.integer("frame") : row;
    ++row;
    const std::string where = timing_.sidecar.string() + ":" + std::to_string(csv.line());
    if (frame < 0) {
      issue_(where, "frame index " + std::to_string(frame) + " is negative: row skipped");
      continue;
    }
    if (frame_count >= 0 && frame >= frame_count) {
      issue_(where, "frame " + std::to_string(frame) + " but '" + video_.filename().string() +
                        "' has " + std::to_string(frame_count) + " frames: row skipped");
      continue;
    }
    if (!frames_.empty() && (t <= frames_.back().first || frame <= frames_.back().second)) {
      issue_(where, t <= frames_.back().first
                        ? "timestamp " + std::to_string(t) +
                              " does not follow the previous one: frame skipped"
                        : "frame index " + std::to_string(frame) +
                              " does not follow the previous one: row skipped");
      continue;
    }
    frames_.emplace_back(t, frame);
  }
}

void VideoFrameSource::loadContainerTimes(const std::vector<std::int64_t>& offsets_ns) {
  for (size_t i = 0; i < offsets_ns.size(); ++i) {
    const TimeNs t = *timing_.start + offsets_ns[i];
    if (!frames_.empty() && t <= frames_.back().first) {
      issue_(video_.string() + ": frame " + std::to_string(i),
             "its timestamp repeats the previous frame's (a duplicated frame): frame skipped");
      continue;
    }
    frames_.emplace_back(t, static_cast<std::int64_t>(i));
  }
}

void VideoFrameSource::noteGaps() {
  std::vector<TimeNs> times;
  times.reserve(frames_.size());
  for (const auto& [t, frame] : frames_) times.push_back(t);
  const FrameTiming timing = analyseFrameTimes(times);
  if (const std::string gaps = timing.describeGaps(); !gaps.empty()) {
    note_(video_.string(), "camera '" + label_ + "': " + gaps + " (dropped by the recorder?)");
  }
}

}  // namespace lookboth::internal
