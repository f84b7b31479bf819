// Private to libs/dataset: one camera's video file as a stream of
// `ImageFrame`s in time order, timed by a sidecar CSV or by the container's
// timestamps plus a start time (doc/formats.md, "Video files").
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lookboth/dataset/image_header.h"
#include "lookboth/dataset/records.h"

namespace lookboth::internal {

/// Receives (where, message).
using VideoIssueSink = std::function<void(const std::string&, const std::string&)>;

/// How a video's frames get their times: a sidecar, else the container's
/// timestamps from `start`.
struct VideoTiming {
  std::filesystem::path sidecar;  ///< CSV `timestamp_ns[,frame]`, one row per frame; empty = none
  std::optional<TimeNs> start;    ///< Time of the first frame [ns, the camera's clock]
  /// Said when neither is given: how the user gives one (a file, an option).
  std::string how_to_time;
};

class VideoFrameSource {
 public:
  /// `issue`: a frame skipped (a repeated or backward time, a frame the video
  /// does not have); `note`: worth knowing, nothing skipped (frames the recorder dropped).
  VideoFrameSource(std::filesystem::path video, std::string label, VideoTiming timing,
                   VideoIssueSink issue, VideoIssueSink note);

  /// The next frame in time order, or nullopt at the end. The video is
  /// examined (its container read, or the sidecar) on the first call.
  std::optional<ImageFrame> next();
  /// The frame size the container declares (known after the first next()).
  ImageSize size() const { return size_; }
  const std::filesystem::path& video() const { return video_; }

 private:
  void load();
  void loadSidecar(std::int64_t frame_count);
  void loadContainerTimes(const std::vector<std::int64_t>& offsets_ns);
  void noteGaps();

  std::filesystem::path video_;
  std::string label_;
  VideoTiming timing_;
  VideoIssueSink issue_, note_;
  bool loaded_ = false;
  ImageSize size_;
  std::vector<std::pair<TimeNs, std::int64_t>> frames_;  ///< (time, frame index)
  size_t next_ = 0;
};

}  // namespace lookboth::internal
