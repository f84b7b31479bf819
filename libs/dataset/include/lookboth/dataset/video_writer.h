// Grey frames written as a video file, as a network camera or its recorder
// writes them: H.264 in MP4 by default, video range (16-235), no B-frames, a
// key frame at a fixed interval. FFmpeg's libraries do the encoding, so the
// file is what `VideoDecoder` and every other reader read.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core/mat.hpp>

namespace lookboth {

struct VideoEncodeOptions {
  /// An FFmpeg encoder that takes video-range YUV 4:2:0: "libx264" (H.264,
  /// what network cameras record), "libx265", "mpeg4", ... (not "mjpeg":
  /// full range only).
  std::string codec = "libx264";
  /// libx264's constant rate factor: lower is better and larger (18 visually
  /// lossless, 23 libx264's default, 28 a low-bitrate recorder). Other codecs ignore it.
  int crf = 23;
  std::string preset = "veryfast";  ///< libx264's speed preset; other codecs ignore it.
  int key_frame_interval = 30;      ///< Frames from one key frame to the next, >= 1.
  double frame_rate_hz = 30;        ///< The frames' nominal rate (the stream's header) [Hz].
  int threads = 1;                  ///< The encoder's threads.
  /// "" when usable, else what is wrong, naming the field.
  std::string check() const;
};

/// Writes one video file. Frames go to `<file>.partial` and the file appears
/// under its own name only when `finish()` succeeds; destroyed unfinished,
/// the partial file is removed. Not thread-safe: one encoder per thread at a time.
class VideoEncoder {
 public:
  /// Opens the encoder for `width` x `height` frames; the container is
  /// chosen by `file`'s extension (.mp4, .mkv, ...). Throws lookboth::Error
  /// naming the file when the codec or the container cannot be opened.
  VideoEncoder(const std::filesystem::path& file, int width, int height,
               const VideoEncodeOptions& options);
  ~VideoEncoder();
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  /// Appends an 8-bit grey frame of the opened size, shown at `time_us`
  /// (microseconds on the video's own clock; must increase from frame to frame).
  void write(const cv::Mat& grey, std::int64_t time_us);
  /// Flushes the encoder, closes the file and renames it into place.
  void finish();
  std::int64_t frames() const;
  const std::filesystem::path& file() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lookboth
