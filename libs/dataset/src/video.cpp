// Video files through FFmpeg: timestamps by demultiplexing, frames by
// decoding forward (seeking when going back, far ahead, or to a key frame
// ahead of the decoder), grey frames
// taken from the luma plane without a colour conversion.
#include "lookboth/dataset/video.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <opencv2/core.hpp>

#include "ffmpeg_util.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

using internal::averror;
using internal::quietFfmpeg;
using internal::videoError;

struct FormatCloser {
  void operator()(AVFormatContext* format) const { avformat_close_input(&format); }
};
struct CodecCloser {
  void operator()(AVCodecContext* codec) const { avcodec_free_context(&codec); }
};
struct PacketFree {
  void operator()(AVPacket* packet) const { av_packet_free(&packet); }
};
struct FrameFree {
  void operator()(AVFrame* frame) const { av_frame_free(&frame); }
};
using FormatPtr = std::unique_ptr<AVFormatContext, FormatCloser>;
using CodecPtr = std::unique_ptr<AVCodecContext, CodecCloser>;
using PacketPtr = std::unique_ptr<AVPacket, PacketFree>;
using FramePtr = std::unique_ptr<AVFrame, FrameFree>;

/// The container opened, with the index of its main video stream.
std::pair<FormatPtr, int> openContainer(const fs::path& file) {
  quietFfmpeg();
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw videoError(file, "video file does not exist");
  AVFormatContext* raw = nullptr;
  int rc = avformat_open_input(&raw, file.c_str(), nullptr, nullptr);
  if (rc < 0) throw videoError(file, "not a video file FFmpeg can read (" + averror(rc) + ")");
  FormatPtr format(raw);
  rc = avformat_find_stream_info(format.get(), nullptr);
  if (rc < 0) throw videoError(file, "cannot read the video's streams (" + averror(rc) + ")");
  const int stream = av_find_best_stream(format.get(), AVMEDIA_TYPE_VIDEO, -1, -1, nullptr, 0);
  if (stream < 0) throw videoError(file, "no video stream in the file");
  return {std::move(format), stream};
}

/// Every frame's presentation time of the stream, in the stream's time base,
/// sorted (= presentation order); empty when the container has no timestamps
/// (a raw stream, whose demuxer invents them from an assumed rate) or a
/// packet lacks its presentation time (decoding times are another clock).
/// Packets the demuxer marks as discarded (before an edit list's start, as in
/// a clip cut without re-encoding) are not frames: the decoder drops them.
/// `count` receives the number of frames; `key_times` (when given) the
/// presentation times of the key frames.
std::vector<std::int64_t> packetTimes(AVFormatContext* format, int stream, const fs::path& file,
                                      std::int64_t& count,
                                      std::vector<std::int64_t>* key_times = nullptr) {
  PacketPtr packet(av_packet_alloc());
  std::vector<std::int64_t> times;
  bool complete = !(format->iformat->flags & AVFMT_NOTIMESTAMPS);
  count = 0;
  int rc = 0;
  while ((rc = av_read_frame(format, packet.get())) >= 0) {
    if (packet->stream_index == stream && !(packet->flags & AV_PKT_FLAG_DISCARD)) {
      ++count;
      if (packet->pts == AV_NOPTS_VALUE) complete = false;
      if (complete) times.push_back(packet->pts);
      if (complete && key_times && (packet->flags & AV_PKT_FLAG_KEY))
        key_times->push_back(packet->pts);
    }
    av_packet_unref(packet.get());
  }
  if (rc != AVERROR_EOF) {
    throw videoError(file,
                     "read error after " + std::to_string(count) + " frames (" + averror(rc) + ")");
  }
  if (!complete) times.clear();
  if (!complete && key_times) key_times->clear();
  std::sort(times.begin(), times.end());
  return times;
}

}  // namespace

VideoProbe probeVideo(const fs::path& file, bool with_times) {
  auto [format, stream] = openContainer(file);
  const AVStream* video = format->streams[stream];
  VideoProbe probe;
  probe.width = video->codecpar->width;
  probe.height = video->codecpar->height;
  probe.codec = avcodec_get_name(video->codecpar->codec_id);
  if (video->avg_frame_rate.num > 0 && video->avg_frame_rate.den > 0)
    probe.frame_rate_hz = av_q2d(video->avg_frame_rate);
  probe.frame_count = video->nb_frames > 0 ? video->nb_frames : -1;
  if (!with_times) return probe;
  const std::vector<std::int64_t> pts = packetTimes(format.get(), stream, file, probe.frame_count);
  const AVRational ns{1, 1000000000};
  for (const std::int64_t t : pts)
    probe.frame_offsets_ns.push_back(av_rescale_q(t - pts.front(), video->time_base, ns));
  return probe;
}

std::string FrameTiming::describeGaps() const {
  if (gaps == 0) return "";
  return std::to_string(dropped) + (dropped == 1 ? " frame" : " frames") + " missing in " +
         std::to_string(gaps) + (gaps == 1 ? " gap" : " gaps") + " (the longest " +
         formatFixed(static_cast<double>(longest_gap_ns) * 1e-9, 3) +
         " s after t=" + formatFixed(static_cast<double>(longest_gap_at) * 1e-9, 3) +
         " s; the frame period is " + formatFixed(period_ns * 1e-6, 2) + " ms)";
}

FrameTiming analyseFrameTimes(const std::vector<TimeNs>& times) {
  FrameTiming timing;
  std::vector<std::int64_t> intervals;
  for (size_t i = 1; i < times.size(); ++i) {
    if (times[i] > times[i - 1]) intervals.push_back(times[i] - times[i - 1]);
  }
  if (intervals.empty()) return timing;
  std::nth_element(intervals.begin(), intervals.begin() + intervals.size() / 2, intervals.end());
  timing.period_ns = static_cast<double>(intervals[intervals.size() / 2]);
  for (size_t i = 1; i < times.size(); ++i) {
    const double interval = static_cast<double>(times[i] - times[i - 1]);
    if (interval < 0.5 * timing.period_ns) {
      ++timing.repeated;
    } else if (interval > 1.5 * timing.period_ns) {
      ++timing.gaps;
      timing.dropped += std::llround(interval / timing.period_ns) - 1;
      if (times[i] - times[i - 1] > timing.longest_gap_ns) {
        timing.longest_gap_ns = times[i] - times[i - 1];
        timing.longest_gap_at = times[i - 1];
      }
    }
  }
  return timing;
}

// ---------------------------------------------------------------------------

struct VideoDecoder::Impl {
  fs::path file;
  int threads = 1;
  FormatPtr format;
  int stream = -1;
  CodecPtr codec;
  PacketPtr packet{av_packet_alloc()};
  FramePtr frame{av_frame_alloc()};
  SwsContext* scaler = nullptr;
  /// The file as opened (modification time, size): a file rewritten in place is opened again.
  std::pair<fs::file_time_type, std::uintmax_t> stamp;
  /// Presentation times of all frames (stream time base), sorted: a decoded
  /// frame's index is the position of its time. Empty for a stream without
  /// timestamps, whose frames are counted instead.
  std::vector<std::int64_t> pts;
  /// Indices of the key frames (presentation order), sorted; empty without timestamps.
  std::vector<std::int64_t> key_frames;
  std::int64_t frame_count = 0;
  std::int64_t next_index = 0;  ///< Index of the frame the decoder gives next.
  bool draining = false;        ///< End of file reached: the decoder is being emptied.
  /// Presentation time of the frame being decoded to; frames before it are
  /// not wanted (none without timestamps).
  std::int64_t wanted_pts = AV_NOPTS_VALUE;
  /// The codec's non-reference frames are referred to by no frame at all
  /// (not so for HEVC's, which higher temporal layers may refer to).
  bool nonref_unused = false;
  std::int64_t output = 0;  ///< Frames the codec put out.
  /// The frame returned last (a window repainting asks for it again).
  std::int64_t last_index = -1;
  bool last_colour = false;
  bool last_unfiltered = false;
  cv::Mat last_image;
  /// The decoder's reference frames were decoded without the loop filter
  /// (a preview): the next frame is decoded from a key frame again.
  bool unfiltered_references = false;

  /// Frames further ahead than this are reached by seeking rather than by
  /// decoding every frame in between (a few groups of pictures).
  static constexpr std::int64_t kSeekAhead = 300;

  ~Impl() { sws_freeContext(scaler); }

  void open() {
    auto [opened, index] = openContainer(file);
    format = std::move(opened);
    stream = index;
    const AVCodecParameters* parameters = format->streams[stream]->codecpar;
    const AVCodec* decoder = avcodec_find_decoder(parameters->codec_id);
    if (!decoder) {
      throw videoError(file, std::string("no decoder for the codec '") +
                                 avcodec_get_name(parameters->codec_id) + "'");
    }
    codec.reset(avcodec_alloc_context3(decoder));
    if (!codec || avcodec_parameters_to_context(codec.get(), parameters) < 0)
      throw videoError(file, "cannot set up the video decoder (out of memory?)");
    const AVCodecID id = parameters->codec_id;
    nonref_unused = id == AV_CODEC_ID_H264 || id == AV_CODEC_ID_MPEG1VIDEO ||
                    id == AV_CODEC_ID_MPEG2VIDEO || id == AV_CODEC_ID_MPEG4 ||
                    id == AV_CODEC_ID_VP8 || id == AV_CODEC_ID_VP9;
    codec->thread_count = threads;
    codec->thread_type = FF_THREAD_FRAME | FF_THREAD_SLICE;
    const int rc = avcodec_open2(codec.get(), decoder, nullptr);
    if (rc < 0) throw videoError(file, "cannot start the video decoder (" + averror(rc) + ")");
    next_index = 0;
    draining = false;
    unfiltered_references = false;
  }

  /// Decodes the next frame into `frame`; false at the end of the stream.
  bool receive() {
    for (;;) {
      int rc = avcodec_receive_frame(codec.get(), frame.get());
      if (rc == 0) {
        ++output;
        return true;
      }
      if (rc != AVERROR(EAGAIN) || draining) return false;
      rc = av_read_frame(format.get(), packet.get());
      if (rc < 0) {
        avcodec_send_packet(codec.get(), nullptr);
        draining = true;
        continue;
      }
      // A damaged packet is not sent on: its frame is missing, the others stay.
      if (packet->stream_index == stream) {
        skipUnwanted();
        avcodec_send_packet(codec.get(), packet.get());
      }
      av_packet_unref(packet.get());
    }
  }

  /// A frame shown before the one wanted, and that no other frame is
  /// predicted from (a non-reference B-frame), is not decoded at all: it
  /// would be dropped, and leaving it out changes no other frame's pixels.
  /// Frames after the one wanted are decoded: they may be asked for next.
  void skipUnwanted() {
    const bool unwanted = nonref_unused && wanted_pts != AV_NOPTS_VALUE &&
                          packet->pts != AV_NOPTS_VALUE && packet->pts < wanted_pts;
    codec->skip_frame = unwanted ? AVDISCARD_NONREF : AVDISCARD_DEFAULT;
  }

  /// The decoded frame's index: the position of its time, else (a stream
  /// without timestamps, or a time the table lacks) the count from the
  /// start; -1 when neither is known (just after a seek).
  std::int64_t indexOfDecoded() const {
    if (!pts.empty()) {
      const std::int64_t t = frame->best_effort_timestamp;
      const auto it = std::lower_bound(pts.begin(), pts.end(), t);
      if (it != pts.end() && *it == t) return it - pts.begin();
    }
    return next_index;
  }

  /// Positions the decoder `back` frames before `index` (at the key frame
  /// before that); false when it cannot seek and starts the file again instead.
  bool seekBefore(std::int64_t index, std::int64_t back) {
    if (!pts.empty()) {
      const auto at = static_cast<size_t>(std::max<std::int64_t>(0, index - back));
      // Halfway to the next frame's time, not the frame's own: a demuxer
      // that seeks on decoding times (MP4) takes the presentation time less
      // one reordering shift for the whole stream, its first frame's; a later
      // key frame's own shift may be a tick smaller (times rounded to the
      // file's clock), and a seek to its exact time lands on the key frame
      // before it: a key interval decoded for nothing.
      const std::int64_t half = at + 1 < pts.size() ? (pts[at + 1] - pts[at]) / 2 : 0;
      if (av_seek_frame(format.get(), stream, pts[at] + half, AVSEEK_FLAG_BACKWARD) >= 0) {
        avcodec_flush_buffers(codec.get());
        draining = false;
        next_index = -1;
        unfiltered_references = false;
        return true;
      }
    }
    open();
    return false;
  }

  /// The decoded frame as the image returned (and kept for a repeated request).
  cv::Mat take(std::int64_t index, bool colour) {
    last_image = convert(colour);
    av_frame_unref(frame.get());
    last_index = index;
    last_colour = colour;
    last_unfiltered = codec->skip_loop_filter == AVDISCARD_ALL;
    return last_image.clone();
  }

  /// Decodes forward to frame `index`; false when the frame is not reached
  /// (`passed` tells whether the decoder went past it: a seek landed too late).
  bool decodeTo(std::int64_t index, bool& passed) {
    passed = false;
    wanted_pts = pts.empty() ? AV_NOPTS_VALUE : pts[static_cast<size_t>(index)];
    while (receive()) {
      const std::int64_t at = indexOfDecoded();
      if (at < 0) {  // a time the table lacks just after a seek: position unknown
        av_frame_unref(frame.get());
        passed = true;
        return false;
      }
      next_index = at + 1;
      // A damaged frame (a packet cut short, lost references) comes out
      // concealed with other frames' pixels: it is not that frame.
      const bool damaged = (frame->flags & AV_FRAME_FLAG_CORRUPT) || frame->decode_error_flags != 0;
      if (at == index && !damaged) return true;
      if (at == index) {
        av_frame_unref(frame.get());
        return false;
      }
      av_frame_unref(frame.get());
      if (at > index) {
        passed = true;
        return false;
      }
    }
    if (next_index < 0) next_index = frame_count;  // ended right after a seek: seek next time
    return false;
  }

  cv::Mat convert(bool colour) {
    const int width = frame->width, height = frame->height;
    const auto format_id = static_cast<AVPixelFormat>(frame->format);
    if (!colour) {
      if (cv::Mat grey = lumaPlane(format_id); !grey.empty()) return grey;
    }
    cv::Mat out(height, width, colour ? CV_8UC3 : CV_8UC1);
    scaler = sws_getCachedContext(scaler, width, height, format_id, width, height,
                                  colour ? AV_PIX_FMT_BGR24 : AV_PIX_FMT_GRAY8, SWS_BILINEAR,
                                  nullptr, nullptr, nullptr);
    if (!scaler) return {};
    // The stream's own colour matrix and range (BT.709 for HD, full range for
    // JPEG-like streams), not swscale's defaults.
    const bool full_range =
        frame->color_range == AVCOL_RANGE_JPEG ||
        std::string(av_get_pix_fmt_name(format_id) ? av_get_pix_fmt_name(format_id) : "")
                .rfind("yuvj", 0) == 0;
    const int space = frame->colorspace == AVCOL_SPC_UNSPECIFIED
                          ? SWS_CS_DEFAULT
                          : static_cast<int>(frame->colorspace);
    sws_setColorspaceDetails(scaler, sws_getCoefficients(space), full_range ? 1 : 0,
                             sws_getCoefficients(SWS_CS_DEFAULT), 1, 0, 1 << 16, 1 << 16);
    std::uint8_t* planes[4] = {out.data, nullptr, nullptr, nullptr};
    int strides[4] = {static_cast<int>(out.step[0]), 0, 0, 0};
    sws_scale(scaler, frame->data, frame->linesize, 0, height, planes, strides);
    return out;
  }

  /// The grey image straight from an 8-bit luma plane (YUV and grey formats),
  /// stretched to full range when the stream uses video range (16-235), as
  /// an image file of the same picture would be; empty for other formats.
  cv::Mat lumaPlane(AVPixelFormat format_id) const {
    const AVPixFmtDescriptor* desc = av_pix_fmt_desc_get(format_id);
    if (!desc || (desc->flags & (AV_PIX_FMT_FLAG_RGB | AV_PIX_FMT_FLAG_PAL |
                                 AV_PIX_FMT_FLAG_BITSTREAM | AV_PIX_FMT_FLAG_HWACCEL)))
      return {};
    const AVComponentDescriptor& luma = desc->comp[0];
    if (luma.plane != 0 || luma.step != 1 || luma.depth != 8 || luma.shift != 0 || luma.offset != 0)
      return {};
    const cv::Mat plane(frame->height, frame->width, CV_8UC1, frame->data[0],
                        static_cast<size_t>(frame->linesize[0]));
    const bool full_range = frame->color_range == AVCOL_RANGE_JPEG || desc->nb_components == 1 ||
                            std::string(desc->name).rfind("yuvj", 0) == 0;
    cv::Mat out;
    if (full_range) {
      plane.copyTo(out);
    } else {
      static const cv::Mat stretch = [] {
        cv::Mat table(1, 256, CV_8UC1);
        for (int v = 0; v < 256; ++v)
          table.at<std::uint8_t>(v) = cv::saturate_cast<std::uint8_t>((v - 16) * 255.0 / 219.0);
        return table;
      }();
      cv::LUT(plane, stretch, out);
    }
    return out;
  }
};

VideoDecoder::VideoDecoder(const fs::path& file, int threads) : impl_(std::make_unique<Impl>()) {
  impl_->file = file;
  std::error_code ec;
  impl_->stamp = {fs::last_write_time(file, ec), fs::file_size(file, ec)};
  impl_->threads = std::max(1, threads);
  {
    auto [format, stream] = openContainer(file);
    std::vector<std::int64_t> key_times;
    impl_->pts = packetTimes(format.get(), stream, file, impl_->frame_count, &key_times);
    for (const std::int64_t t : key_times) {
      const auto it = std::lower_bound(impl_->pts.begin(), impl_->pts.end(), t);
      if (it != impl_->pts.end() && *it == t) impl_->key_frames.push_back(it - impl_->pts.begin());
    }
    std::sort(impl_->key_frames.begin(), impl_->key_frames.end());
  }
  impl_->open();
}

VideoDecoder::~VideoDecoder() = default;

const fs::path& VideoDecoder::file() const { return impl_->file; }
bool VideoDecoder::isCurrent() const {
  std::error_code ec;
  const auto now =
      std::make_pair(fs::last_write_time(impl_->file, ec), fs::file_size(impl_->file, ec));
  return !ec && now == impl_->stamp;
}
int VideoDecoder::width() const { return impl_->codec->width; }
const std::vector<std::int64_t>& VideoDecoder::keyFrames() const { return impl_->key_frames; }
std::int64_t VideoDecoder::framesOutput() const { return impl_->output; }
int VideoDecoder::height() const { return impl_->codec->height; }

cv::Mat VideoDecoder::keyFramePreview(std::int64_t index) {
  Impl& d = *impl_;
  if (!std::binary_search(d.key_frames.begin(), d.key_frames.end(), index))
    return frame(index, false);
  if (index == d.last_index && !d.last_colour) return d.last_image.clone();
  // Whatever happens, the filter is back on after the preview and the
  // decoder's references are taken as unfiltered.
  struct Restore {
    Impl& d;
    ~Restore() {
      if (d.codec) d.codec->skip_loop_filter = AVDISCARD_DEFAULT;
      d.unfiltered_references = true;
    }
  } restore{d};
  d.codec->skip_loop_filter = AVDISCARD_ALL;
  return frame(index, false);
}

cv::Mat VideoDecoder::frame(std::int64_t index, bool colour) {
  Impl& d = *impl_;
  if (index < 0 || index >= d.frame_count) return {};
  if (index == d.last_index && colour == d.last_colour &&
      (!d.last_unfiltered || d.codec->skip_loop_filter == AVDISCARD_ALL))
    return d.last_image.clone();
  // After a preview the decoder holds unfiltered references: no frame is
  // decoded on from them (the decoder's position made unknown: a seek).
  if (d.unfiltered_references && d.codec->skip_loop_filter != AVDISCARD_ALL)
    d.next_index = std::numeric_limits<std::int64_t>::max() / 2;
  bool passed = false;
  // A key frame between the next frame and this one: decoding starts there
  // (a seek) instead of decoding every frame before it.
  const auto key = std::upper_bound(d.key_frames.begin(), d.key_frames.end(), index);
  const bool key_ahead = key != d.key_frames.begin() && *std::prev(key) > d.next_index;
  if (key_ahead && index > d.next_index && d.seekBefore(*std::prev(key), 0)) {
    if (d.decodeTo(index, passed)) return d.take(index, colour);
    if (!passed) return {};
  } else if (index >= d.next_index && index <= d.next_index + Impl::kSeekAhead) {
    // Forward: every frame up to it decoded; past it without it, it is missing.
    return d.decodeTo(index, passed) ? d.take(index, colour) : cv::Mat();
  } else if (key != d.key_frames.begin() && index < d.next_index &&
             d.seekBefore(*std::prev(key), 0)) {
    // Back: from the key frame before it, when the container lists them.
    if (d.decodeTo(index, passed)) return d.take(index, colour);
    if (!passed) return {};
  }
  // Key frames are found by decoding time, which runs ahead of presentation
  // time: a seek starts a little before the frame, further back while it
  // lands past it, and from the start of the file at last.
  for (const std::int64_t back : {16, 128, 1024}) {
    const bool seeked = d.seekBefore(index, back);
    if (d.decodeTo(index, passed)) return d.take(index, colour);
    if (!seeked || !passed) return {};
  }
  d.open();
  return d.decodeTo(index, passed) ? d.take(index, colour) : cv::Mat();
}

namespace internal {

std::string averror(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, text, sizeof text);
  return text;
}

void quietFfmpeg() {
  static std::once_flag once;
  std::call_once(once, [] { av_log_set_level(AV_LOG_FATAL); });
}

Error videoError(const fs::path& file, const std::string& message) {
  return Error({file.string(), 0, "", ""}, message);
}

}  // namespace internal

}  // namespace lookboth
