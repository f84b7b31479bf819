#include "lookboth/dataset/frame_decoder.h"

#include <algorithm>
#include <opencv2/imgcodecs.hpp>

#include "lookboth/dataset/video.h"
#include "lookboth/geometry/time.h"

namespace lookboth {
namespace {

/// Video files kept open at once by one decoder: a camera's own file, and a
/// few more for callers that go back and forth between cameras (the desktop app).
constexpr size_t kOpenVideos = 4;

}  // namespace

FrameDecoder::FrameDecoder(int video_threads) : video_threads_(video_threads) {}
FrameDecoder::~FrameDecoder() = default;
FrameDecoder::FrameDecoder(FrameDecoder&&) noexcept = default;
FrameDecoder& FrameDecoder::operator=(FrameDecoder&&) noexcept = default;

VideoDecoder& FrameDecoder::video(const std::filesystem::path& file) {
  for (size_t i = 0; i < videos_.size(); ++i) {
    if (videos_[i]->file() == file && !videos_[i]->isCurrent()) {
      videos_.erase(videos_.begin() + static_cast<std::ptrdiff_t>(i));
      break;
    }
    if (videos_[i]->file() == file) {
      std::rotate(videos_.begin(), videos_.begin() + static_cast<std::ptrdiff_t>(i),
                  videos_.begin() + static_cast<std::ptrdiff_t>(i) + 1);
      return *videos_.front();
    }
  }
  if (videos_.size() >= kOpenVideos) videos_.pop_back();
  videos_.insert(videos_.begin(), std::make_unique<VideoDecoder>(file, video_threads_));
  return *videos_.front();
}

cv::Mat FrameDecoder::decode(const ImageFrame& frame, FrameColour colour) {
  const int flags = colour == FrameColour::kGrey ? cv::IMREAD_GRAYSCALE : cv::IMREAD_UNCHANGED;
  if (frame.encoded) {
    const cv::Mat bytes(1, static_cast<int>(frame.encoded->size()), CV_8UC1,
                        const_cast<std::uint8_t*>(frame.encoded->data()));
    return cv::imdecode(bytes, flags);
  }
  if (isVideoFrame(frame)) {
    return video(frame.video_file).frame(frame.video_frame, colour == FrameColour::kAsStored);
  }
  return cv::imread(frame.image_file.string(), flags);
}

cv::Mat FrameDecoder::decodePreview(const ImageFrame& frame) {
  if (!isVideoFrame(frame)) return decode(frame, FrameColour::kGrey);
  return video(frame.video_file).keyFramePreview(frame.video_frame);
}

std::optional<ImageSize> FrameDecoder::size(const ImageFrame& frame) {
  if (frame.encoded) return encodedImageSize(frame.encoded->data(), frame.encoded->size());
  if (isVideoFrame(frame)) {
    const VideoDecoder& decoder = video(frame.video_file);
    return ImageSize{decoder.width(), decoder.height()};
  }
  return imageFileSize(frame.image_file);
}

std::vector<std::int64_t> FrameDecoder::keyFrames(const ImageFrame& frame) {
  if (!isVideoFrame(frame)) return {};
  return video(frame.video_file).keyFrames();
}

std::string frameName(const ImageFrame& frame) {
  if (frame.encoded) return "the frame at t=" + formatSeconds(frame.t) + " (embedded)";
  if (isVideoFrame(frame)) {
    return "frame " + std::to_string(frame.video_frame) + " of '" + frame.video_file.string() + "'";
  }
  return "'" + frame.image_file.string() + "'";
}

}  // namespace lookboth
