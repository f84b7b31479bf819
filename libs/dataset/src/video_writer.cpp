// Grey frames encoded through FFmpeg: the grey levels become video-range
// luma (what cameras write and what `VideoDecoder` stretches back), the
// chroma planes neutral.
#include "lookboth/dataset/video_writer.h"

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/opt.h>
}

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>

#include "ffmpeg_util.h"
#include "lookboth/core/error.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

using internal::averror;
using internal::videoError;

/// Full-range grey to video-range luma (16-235), rounded.
const cv::Mat& videoRangeTable() {
  static const cv::Mat table = [] {
    cv::Mat t(1, 256, CV_8UC1);
    for (int g = 0; g < 256; ++g)
      t.at<std::uint8_t>(g) = static_cast<std::uint8_t>(16 + (g * 219 + 127) / 255);
    return t;
  }();
  return table;
}

}  // namespace

std::string VideoEncodeOptions::check() const {
  if (codec.empty()) return "'codec': empty";
  if (crf < 0 || crf > 51) return "'crf': must be in [0, 51], got " + std::to_string(crf);
  if (key_frame_interval < 1 || key_frame_interval > 100000)
    return "'key_frame_interval': must be in [1, 100000], got " +
           std::to_string(key_frame_interval);
  if (!(frame_rate_hz > 0 && frame_rate_hz <= 1000)) return "'frame_rate_hz': must be in (0, 1000]";
  if (threads < 1 || threads > 64)
    return "'threads': must be in [1, 64], got " + std::to_string(threads);
  return "";
}

struct VideoEncoder::Impl {
  fs::path file, partial;
  AVFormatContext* format = nullptr;
  AVCodecContext* codec = nullptr;
  AVStream* stream = nullptr;
  AVFrame* frame = nullptr;
  AVPacket* packet = nullptr;
  std::int64_t frames = 0;
  std::int64_t last_time_us = 0;
  std::int64_t last_pts = 0;  ///< On the codec's 90 kHz clock.
  bool header_written = false;
  bool finished = false;  ///< The trailer written, or tried: nothing more goes in.
  bool renamed = false;   ///< The file is in place under its name.

  ~Impl() {
    if (header_written && !finished) av_write_trailer(format);
    if (format && format->pb) avio_closep(&format->pb);
    avformat_free_context(format);
    avcodec_free_context(&codec);
    av_frame_free(&frame);
    av_packet_free(&packet);
    if (!renamed && !partial.empty()) {
      std::error_code ec;
      fs::remove(partial, ec);
    }
  }

  void open(int width, int height, const VideoEncodeOptions& options) {
    const AVOutputFormat* container = av_guess_format(nullptr, file.c_str(), nullptr);
    if (!container) {
      throw videoError(file, "no container for the extension '" + file.extension().string() +
                                 "' (use .mp4 or .mkv)");
    }
    const AVCodec* encoder = avcodec_find_encoder_by_name(options.codec.c_str());
    if (!encoder) throw videoError(file, "FFmpeg has no encoder '" + options.codec + "'");
    int rc = avformat_alloc_output_context2(&format, container, nullptr, partial.c_str());
    if (rc < 0) throw videoError(file, "cannot set up the container (" + averror(rc) + ")");
    codec = avcodec_alloc_context3(encoder);
    codec->width = width;
    codec->height = height;
    codec->pix_fmt = AV_PIX_FMT_YUV420P;
    codec->color_range = AVCOL_RANGE_MPEG;
    // Microseconds, the frames' own times, where the encoder takes them
    // (libx264, libx265); else a thousandth of a frame (MPEG-4 part 2 takes
    // no finer than 1/65535 s), to which the times given are rounded.
    const bool microseconds = options.codec == "libx264" || options.codec == "libx265";
    codec->time_base = AVRational{
        1, microseconds
               ? 1000000
               : static_cast<int>(std::min(65535.0, std::round(1000 * options.frame_rate_hz)))};
    codec->framerate = av_d2q(options.frame_rate_hz, 100000);
    codec->gop_size = options.key_frame_interval;
    codec->keyint_min = options.key_frame_interval;
    codec->max_b_frames = 0;  // as network cameras: every frame decodes in order
    codec->thread_count = options.threads;
    if (format->oformat->flags & AVFMT_GLOBALHEADER) codec->flags |= AV_CODEC_FLAG_GLOBAL_HEADER;
    if (options.codec == "libx264") {
      av_opt_set(codec->priv_data, "preset", options.preset.c_str(), 0);
      av_opt_set(codec->priv_data, "crf", std::to_string(options.crf).c_str(), 0);
      // Key frames at the interval only: a scene cut would add others.
      av_opt_set(codec->priv_data, "x264-params", "scenecut=0", 0);
    }
    rc = avcodec_open2(codec, encoder, nullptr);
    if (rc < 0)
      throw videoError(file,
                       "cannot open the encoder '" + options.codec + "' (" + averror(rc) + ")");
    stream = avformat_new_stream(format, nullptr);
    if (!stream) throw videoError(file, "cannot add a stream");
    stream->time_base = codec->time_base;
    avcodec_parameters_from_context(stream->codecpar, codec);
    rc = avio_open(&format->pb, partial.c_str(), AVIO_FLAG_WRITE);
    if (rc < 0) throw videoError(partial, "cannot create the file (" + averror(rc) + ")");
    rc = avformat_write_header(format, nullptr);
    if (rc < 0) throw videoError(file, "cannot write the container's header (" + averror(rc) + ")");
    header_written = true;
    frame = av_frame_alloc();
    packet = av_packet_alloc();
    frame->format = codec->pix_fmt;
    frame->width = width;
    frame->height = height;
    frame->color_range = AVCOL_RANGE_MPEG;
    rc = av_frame_get_buffer(frame, 0);
    if (rc < 0) throw videoError(file, "cannot allocate a frame (" + averror(rc) + ")");
  }

  /// Sends `input` (null: the end) and writes every packet the encoder gives back.
  void send(const AVFrame* input) {
    int rc = avcodec_send_frame(codec, input);
    if (rc < 0) throw videoError(file, "encoding failed (" + averror(rc) + ")");
    while ((rc = avcodec_receive_packet(codec, packet)) >= 0) {
      av_packet_rescale_ts(packet, codec->time_base, stream->time_base);
      packet->stream_index = stream->index;
      rc = av_interleaved_write_frame(format, packet);
      if (rc < 0) throw videoError(partial, "cannot write (disk full?) (" + averror(rc) + ")");
    }
    if (rc != AVERROR(EAGAIN) && rc != AVERROR_EOF)
      throw videoError(file, "encoding failed (" + averror(rc) + ")");
  }
};

VideoEncoder::VideoEncoder(const fs::path& file, int width, int height,
                           const VideoEncodeOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (const std::string why = options.check(); !why.empty()) throw videoError(file, why);
  if (width < 2 || height < 2 || width % 2 || height % 2) {
    throw videoError(file, "frames of " + std::to_string(width) + "x" + std::to_string(height) +
                               ": the encoder needs an even width and height");
  }
  internal::quietFfmpeg();
  impl_->file = file;
  impl_->partial = file.string() + ".partial";
  impl_->open(width, height, options);
}

VideoEncoder::~VideoEncoder() = default;

void VideoEncoder::write(const cv::Mat& grey, std::int64_t time_us) {
  Impl& m = *impl_;
  if (m.finished) throw videoError(m.file, "frame written after the video was finished");
  if (grey.type() != CV_8UC1 || grey.cols != m.codec->width || grey.rows != m.codec->height) {
    throw videoError(m.file, "frame " + std::to_string(m.frames) + " is not 8-bit grey of " +
                                 std::to_string(m.codec->width) + "x" +
                                 std::to_string(m.codec->height));
  }
  const std::int64_t pts = av_rescale_q(time_us, AVRational{1, 1000000}, m.codec->time_base);
  if (m.frames > 0 && (time_us <= m.last_time_us || pts <= m.last_pts)) {
    throw videoError(m.file, "frame " + std::to_string(m.frames) + " at " +
                                 std::to_string(time_us) +
                                 " us does not follow the previous one at " +
                                 std::to_string(m.last_time_us) + " us");
  }
  const int rc = av_frame_make_writable(m.frame);
  if (rc < 0) throw videoError(m.file, "cannot reuse the frame (" + averror(rc) + ")");
  const cv::Mat luma(grey.rows, grey.cols, CV_8UC1, m.frame->data[0],
                     static_cast<std::size_t>(m.frame->linesize[0]));
  cv::LUT(grey, videoRangeTable(), luma);
  for (int plane = 1; plane <= 2; ++plane) {
    cv::Mat(grey.rows / 2, grey.cols / 2, CV_8UC1, m.frame->data[plane],
            static_cast<std::size_t>(m.frame->linesize[plane]))
        .setTo(128);
  }
  m.frame->pts = pts;
  m.send(m.frame);
  m.last_time_us = time_us;
  m.last_pts = pts;
  ++m.frames;
}

void VideoEncoder::finish() {
  Impl& m = *impl_;
  if (m.finished) return;
  m.send(nullptr);
  int rc = av_write_trailer(m.format);
  m.finished = true;
  if (rc < 0) throw videoError(m.partial, "cannot finish the file (" + averror(rc) + ")");
  rc = avio_closep(&m.format->pb);
  if (rc < 0) throw videoError(m.partial, "cannot close the file (" + averror(rc) + ")");
  std::error_code ec;
  fs::rename(m.partial, m.file, ec);
  if (ec) throw videoError(m.file, "cannot rename the finished video into place: " + ec.message());
  m.renamed = true;
}

std::int64_t VideoEncoder::frames() const { return impl_->frames; }

const fs::path& VideoEncoder::file() const { return impl_->file; }

}  // namespace lookboth
