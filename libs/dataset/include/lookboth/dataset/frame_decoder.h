// The one way to turn an `ImageFrame` into pixels, wherever its frame is: an
// image file, encoded bytes in memory, or a frame of a video file. Detection,
// odometry, the pictures of the report and the desktop app all decode through
// it, so that they see the same pixels.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "lookboth/dataset/image_header.h"
#include "lookboth/dataset/records.h"

namespace lookboth {

class VideoDecoder;

enum class FrameColour {
  kGrey,      ///< 8-bit grey (what the detectors and the odometry use)
  kAsStored,  ///< as the file holds it: grey or colour for images, BGR for a video frame
};

/// Decodes frames; keeps the last few video files open, positioned after the
/// frame decoded last, so that a camera's frames in time order decode as a
/// stream. Not thread-safe: one decoder per thread.
class FrameDecoder {
 public:
  /// `video_threads`: FFmpeg's decoding threads per video file.
  explicit FrameDecoder(int video_threads = 1);
  ~FrameDecoder();
  FrameDecoder(FrameDecoder&&) noexcept;
  FrameDecoder& operator=(FrameDecoder&&) noexcept;

  /// The frame's pixels; empty when it cannot be decoded (a damaged image or
  /// video frame). Throws lookboth::Error naming the file when a video file
  /// cannot be opened at all.
  cv::Mat decode(const ImageFrame& frame, FrameColour colour);

  /// A key frame of a video as a grey preview (VideoDecoder::keyFramePreview:
  /// without the loop filter, not the frame's exact pixels); any other frame
  /// as decode(frame, kGrey).
  cv::Mat decodePreview(const ImageFrame& frame);
  /// The frame's size without decoding it: from an image's header or a
  /// video's container; nullopt when the format does not tell (decode it then).
  std::optional<ImageSize> size(const ImageFrame& frame);

  /// For a frame of a video file, the indices (ImageFrame::video_frame) of
  /// that file's key frames; empty for image frames.
  std::vector<std::int64_t> keyFrames(const ImageFrame& frame);

 private:
  VideoDecoder& video(const std::filesystem::path& file);

  int video_threads_;
  std::vector<std::unique_ptr<VideoDecoder>> videos_;  ///< Most recently used first.
};

/// How messages name a frame: "'/data/cam03/frames/17.png'", "frame 412 of
/// '/data/cam03/video.mp4'" or "the frame at t=12.300 s (embedded)".
std::string frameName(const ImageFrame& frame);

/// Whether the frame is a frame of a video file.
inline bool isVideoFrame(const ImageFrame& frame) { return !frame.video_file.empty(); }

}  // namespace lookboth
