// Video files as a camera's frames: what the container says about them
// (read without decoding) and frames decoded one after the other, straight
// from the file. The FFmpeg libraries (Debian's libavformat/libavcodec) do the
// work: one library gives both the container's timestamps without decoding
// and the frames with those timestamps, so "frame n" is the same frame for the
// reader that times it and the decoder that decodes it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "lookboth/geometry/time.h"

namespace lookboth {

/// A video's stream as the container describes it.
struct VideoProbe {
  int width = 0;             ///< [px]
  int height = 0;            ///< [px]
  std::string codec;         ///< FFmpeg's codec name: "h264", "hevc", "mjpeg", ...
  double frame_rate_hz = 0;  ///< The stream's average rate; 0 when the container does not say.
  /// Frames the container holds (counted when `with_times`, else its header's count; -1 unknown).
  std::int64_t frame_count = -1;
  /// Presentation time of each frame, in presentation order, relative to the
  /// first frame [ns]. Empty unless asked for, or when the container has no
  /// timestamps (a raw elementary stream): its frames are then timed by a sidecar.
  std::vector<std::int64_t> frame_offsets_ns;
};

/// Opens `file` and describes its first video stream. With `with_times`, every
/// packet of the stream is read (demultiplexed, not decoded) for its
/// timestamp. Throws lookboth::Error naming the file when it is not a video
/// FFmpeg can read.
VideoProbe probeVideo(const std::filesystem::path& file, bool with_times);

/// Gaps (dropped frames) and repeats in a camera's frame times.
struct FrameTiming {
  double period_ns = 0;      ///< The median interval between frames.
  std::int64_t dropped = 0;  ///< Frames missing in the gaps (interval > 1.5 periods).
  std::int64_t gaps = 0;     ///< Intervals longer than 1.5 periods.
  std::int64_t longest_gap_ns = 0;
  TimeNs longest_gap_at = 0;  ///< Time of the frame before the longest gap.
  std::int64_t repeated = 0;  ///< Frames whose time does not follow the previous one.
  /// "5 frames missing in 2 gaps (the longest 0.200 s after t=12.300 s)"; empty when none.
  std::string describeGaps() const;
};

/// Measures `times` (in presentation order; need not increase).
FrameTiming analyseFrameTimes(const std::vector<TimeNs>& times);

/// Decodes the frames of one video file, forward one after the other; going
/// back, or far ahead, seeks to the key frame before and decodes from there.
/// Not thread-safe: one decoder per thread.
class VideoDecoder {
 public:
  /// `threads`: FFmpeg's decoding threads for this file (1: decode on the caller's thread).
  explicit VideoDecoder(const std::filesystem::path& file, int threads = 1);
  ~VideoDecoder();
  VideoDecoder(const VideoDecoder&) = delete;
  VideoDecoder& operator=(const VideoDecoder&) = delete;

  const std::filesystem::path& file() const;
  /// False once the file on disk is no longer the one opened (rewritten or removed).
  bool isCurrent() const;
  int width() const;
  int height() const;
  /// Indices of the frames that decode alone (key frames), in presentation
  /// order; empty when the container has no timestamps. Going to a frame
  /// after a key frame further ahead starts decoding at that key frame.
  const std::vector<std::int64_t>& keyFrames() const;

  /// Frame `index` (0 = the first in presentation order): 8-bit grey, or
  /// 8-bit BGR when `colour`. Empty when the file has no such frame or it
  /// cannot be decoded (a damaged stretch); throws only when the file cannot be read at all.
  cv::Mat frame(std::int64_t index, bool colour);
  /// A key frame's preview: decoded without the codec's loop filter (H.264
  /// and HEVC deblocking), about 15 % faster, its pixels within compression's
  /// own differences of the frame's; enough to tell whether anything moved.
  /// Any other frame is decoded as by frame(). The frame decoded next after
  /// a preview starts again from a key frame, so no filtered frame is ever
  /// predicted from unfiltered pixels.
  cv::Mat keyFramePreview(std::int64_t index);

  /// Frames the codec has put out since this decoder was made: those
  /// returned and those decoded on the way to them, what the requests cost
  /// (not counted: frames a seek drops from the codec's reordering delay).
  /// On the way to a frame of H.264, MPEG-1/2/4 part 2, VP8 or VP9, the
  /// frames shown before it that no other frame is predicted from (B-frames
  /// no other refers to) are not decoded at all.
  std::int64_t framesOutput() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lookboth
