// Video files as a camera's frames: written by an independent writer
// (ffmpeg, through scripts/frames_to_video.py), read back by lookboth. Every
// frame carries its own index as a bar code, so a decoded frame says which
// one it is whatever the decoder did (B-frames, seeking, key frames).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "lookboth/core/error.h"
#include "lookboth/dataset/convert.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/dataset/frame_decoder.h"
#include "lookboth/dataset/video.h"
#include "lookboth/dataset/video_writer.h"

namespace lookboth {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 160, kHeight = 120, kBits = 10;
constexpr TimeNs kStart = 1'700'000'000'000'000'000;
constexpr TimeNs kPeriod = 40'000'000;  // 25 Hz: a whole number of microseconds

/// Frame `index` as a picture: 10 vertical bars, white for a 1 bit.
cv::Mat barCode(int index) {
  cv::Mat image(kHeight, kWidth, CV_8UC1, cv::Scalar(0));
  const int bar = kWidth / kBits;
  for (int b = 0; b < kBits; ++b) {
    if (index & (1 << b)) image.colRange(b * bar, (b + 1) * bar).setTo(255);
  }
  return image;
}

/// The index a decoded frame shows (grey or BGR).
int readBarCode(const cv::Mat& image) {
  cv::Mat grey = image;
  if (image.channels() == 3) cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  const int bar = kWidth / kBits;
  int index = 0;
  for (int b = 0; b < kBits; ++b) {
    if (grey.at<std::uint8_t>(kHeight / 2, b * bar + bar / 2) > 128) index |= 1 << b;
  }
  return index;
}

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("lookboth_video_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// A camera folder whose `count` frames become `video.mp4` (ffmpeg), timed
/// as `timing` says; `extra` goes to the script (--drop, --codec). Returns
/// the frames' times (all of them, dropped ones too).
std::vector<TimeNs> makeCameraVideo(const fs::path& folder, int count, const std::string& timing,
                                    const std::string& extra = "",
                                    TimeNs (*offset)(int) = nullptr) {
  fs::create_directories(folder / "frames");
  std::ofstream csv(folder / "frames.csv");
  csv << "timestamp_ns,file\n";
  std::vector<TimeNs> times;
  for (int i = 0; i < count; ++i) {
    const TimeNs t = kStart + (offset ? offset(i) : i * kPeriod);
    times.push_back(t);
    const std::string name = "frames/" + std::to_string(i) + ".png";
    cv::imwrite((folder / name).string(), barCode(i));
    csv << t << "," << name << "\n";
  }
  csv.close();
  const std::string script = std::string(LOOKBOTH_SHARE_DIR) + "/../../scripts/frames_to_video.py";
  const std::string command = "python3 '" + script + "' '" + folder.string() + "' --timing " +
                              timing + " --crf 10 " + extra;
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  return times;
}

/// A folder dataset with one environment camera, cam00, whose frames are a video.
fs::path makeVideoDataset(const std::string& name, int count, const std::string& timing,
                          const std::string& extra = "") {
  const fs::path root = scratch(name) / "site";
  fs::create_directories(root / "cameras/cam00");
  std::ofstream(root / "marker.yaml") << "dictionary: DICT_4X4_50\nid: 7\nsize_m: 0.2\n";
  std::ofstream(root / "cameras/cam00/calibration.yaml")
      << "lookboth_camera: 1\nmodel: pinhole\nwidth: 160\nheight: 120\n"
         "params: {fx: 100, fy: 100, cx: 79.5, cy: 59.5}\n";
  makeCameraVideo(root / "cameras/cam00", count, timing, extra);
  return root;
}

struct ReadBack {
  std::vector<ImageFrame> frames;
  std::vector<DatasetIssue> issues;
};

ReadBack readFrames(const fs::path& dataset, const DatasetReadOptions& options = {}) {
  ReadBack out;
  auto reader = DatasetReader::open(dataset, options);
  while (auto record = reader->next()) {
    if (const auto* frame = std::get_if<ImageFrame>(&*record)) out.frames.push_back(*frame);
  }
  out.issues = reader->issues();
  return out;
}

TEST(Video, ProbeGivesSizeCodecAndTheFramesTimesWithoutDecoding) {
  const fs::path folder = scratch("probe") / "cam";
  const std::vector<TimeNs> times = makeCameraVideo(folder, 40, "container");
  const VideoProbe probe = probeVideo(folder / "video.mp4", true);
  EXPECT_EQ(probe.width, kWidth);
  EXPECT_EQ(probe.height, kHeight);
  EXPECT_EQ(probe.codec, "h264");
  EXPECT_EQ(probe.frame_count, 40);
  ASSERT_EQ(probe.frame_offsets_ns.size(), 40u);
  for (size_t i = 0; i < times.size(); ++i)
    EXPECT_EQ(probe.frame_offsets_ns[i], times[i] - times[0]) << i;
  const VideoProbe header_only = probeVideo(folder / "video.mp4", false);
  EXPECT_TRUE(header_only.frame_offsets_ns.empty());
  EXPECT_EQ(header_only.frame_count, 40);  // an MP4's header says
}

TEST(Video, DecoderGivesEveryFrameForwardBackwardAndFarAhead) {
  const fs::path folder = scratch("decode") / "cam";
  makeCameraVideo(folder, 120, "container", "--keyint 50");
  VideoDecoder decoder(folder / "video.mp4");
  EXPECT_EQ(decoder.width(), kWidth);
  for (int i = 0; i < 120; ++i) {
    const cv::Mat grey = decoder.frame(i, false);
    ASSERT_FALSE(grey.empty()) << i;
    EXPECT_EQ(grey.type(), CV_8UC1);
    EXPECT_EQ(readBarCode(grey), i);
  }
  // Back, far ahead, every fifth frame, and colour.
  for (const int i : {3, 0, 117, 64, 65, 10, 99, 50, 49}) {
    const cv::Mat image = decoder.frame(i, i % 2 == 1);
    ASSERT_FALSE(image.empty()) << i;
    EXPECT_EQ(image.channels(), i % 2 == 1 ? 3 : 1);
    EXPECT_EQ(readBarCode(image), i);
  }
  for (int i = 0; i < 120; i += 5) EXPECT_EQ(readBarCode(decoder.frame(i, false)), i);
  EXPECT_TRUE(decoder.frame(120, false).empty());
  EXPECT_TRUE(decoder.frame(-1, false).empty());
}

TEST(Video, VideoRangeGreyIsStretchedToFullRangeLikeTheImage) {
  const fs::path folder = scratch("range") / "cam";
  makeCameraVideo(folder, 4, "container");
  VideoDecoder decoder(folder / "video.mp4");
  const cv::Mat grey = decoder.frame(3, false);  // bars 0 and 1 white, the rest black
  EXPECT_GE(grey.at<std::uint8_t>(kHeight / 2, 10), 250);
  EXPECT_LE(grey.at<std::uint8_t>(kHeight / 2, kWidth - 10), 5);
}

TEST(Video, OtherCodecsDecode) {
  const fs::path folder = scratch("mjpeg") / "cam";
  makeCameraVideo(folder, 12, "container", "--codec mjpeg");
  EXPECT_EQ(probeVideo(folder / "video.mp4", false).codec, "mjpeg");
  VideoDecoder decoder(folder / "video.mp4");
  for (const int i : {0, 7, 2, 11}) EXPECT_EQ(readBarCode(decoder.frame(i, false)), i);
}

TEST(Video, FolderDatasetTimesFramesByTheContainerFromVideoYaml) {
  const fs::path site = makeVideoDataset("container", 30, "container");
  const ReadBack read = readFrames(site);
  ASSERT_EQ(read.frames.size(), 30u);
  FrameDecoder decoder;
  for (size_t i = 0; i < read.frames.size(); ++i) {
    const ImageFrame& frame = read.frames[i];
    EXPECT_EQ(frame.sensor, "cam00");
    EXPECT_EQ(frame.t, kStart + static_cast<TimeNs>(i) * kPeriod);
    EXPECT_EQ(frame.video_frame, static_cast<std::int64_t>(i));
    EXPECT_EQ(readBarCode(decoder.decode(frame, FrameColour::kGrey)), static_cast<int>(i));
    const std::optional<ImageSize> size = decoder.size(frame);
    ASSERT_TRUE(size);
    EXPECT_EQ(size->width, kWidth);
  }
  EXPECT_TRUE(read.issues.empty());
}

TEST(Video, DroppedFramesAreReportedAsANoteEvenWhenStrict) {
  const fs::path site = makeVideoDataset("dropped", 30, "container", "--drop 10,11,12,20");
  DatasetReadOptions strict;
  strict.strict = true;
  const ReadBack read = readFrames(site, strict);
  ASSERT_EQ(read.frames.size(), 26u);
  // The frames after a gap keep their own times and pictures.
  EXPECT_EQ(read.frames[10].t, kStart + 13 * kPeriod);
  FrameDecoder decoder;
  EXPECT_EQ(readBarCode(decoder.decode(read.frames[10], FrameColour::kGrey)), 13);
  ASSERT_EQ(read.issues.size(), 1u);
  EXPECT_TRUE(read.issues[0].note);
  EXPECT_NE(read.issues[0].message.find("4 frames missing in 2 gaps"), std::string::npos)
      << read.issues[0].message;
  EXPECT_NE(read.issues[0].message.find("the longest 0.160 s"), std::string::npos);
}

TEST(Video, SidecarTimesFramesAndSkipsBadRowsAsIssues) {
  const fs::path site = makeVideoDataset("sidecar", 10, "sidecar");
  const fs::path csv = site / "cameras/cam00/video.csv";
  std::ofstream(csv) << "timestamp_ns,frame\n100,0\n200,1\n200,2\n300,4\n250,5\n400,3\n500,12\n";
  const ReadBack read = readFrames(site);
  ASSERT_EQ(read.frames.size(), 3u);  // 100/0, 200/1, 300/4
  EXPECT_EQ(read.frames[2].t, 300);
  EXPECT_EQ(read.frames[2].video_frame, 4);
  FrameDecoder decoder;
  EXPECT_EQ(readBarCode(decoder.decode(read.frames[2], FrameColour::kGrey)), 4);
  std::string all;
  for (const DatasetIssue& issue : read.issues) all += issue.where + ": " + issue.message + "\n";
  EXPECT_NE(all.find("video.csv:4: timestamp 200 does not follow"), std::string::npos) << all;
  EXPECT_NE(all.find("video.csv:6: timestamp 250"), std::string::npos) << all;
  EXPECT_NE(all.find("video.csv:7: frame index 3 does not follow"), std::string::npos) << all;
  EXPECT_NE(all.find("video.csv:8: frame 12 but 'video.mp4' has 10 frames"), std::string::npos)
      << all;
}

TEST(Video, ClearErrorsNameTheFileAndSayWhatToDo) {
  const fs::path site = makeVideoDataset("errors", 6, "container");
  const fs::path folder = site / "cameras/cam00";
  auto errorOf = [&] {
    try {
      readFrames(site);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  fs::remove(folder / "video.yaml");
  std::string message = errorOf();
  EXPECT_NE(message.find("video.mp4"), std::string::npos) << message;
  EXPECT_NE(message.find("video.yaml"), std::string::npos) << message;
  std::ofstream(folder / "video.yaml") << "start_timestamp_ns: soon\n";
  message = errorOf();
  EXPECT_NE(message.find("video.yaml:1: 'start_timestamp_ns'"), std::string::npos) << message;
  std::ofstream(folder / "video.yaml") << "start_timestamp_ns: 5\n";
  std::ofstream(folder / "frames.csv") << "timestamp_ns,file\n";
  message = errorOf();
  EXPECT_NE(message.find("both frames.csv and video.mp4"), std::string::npos) << message;
  fs::remove(folder / "frames.csv");
  std::ofstream(folder / "video.mp4", std::ios::trunc) << "not a video\n";
  message = errorOf();
  EXPECT_NE(message.find("video.mp4"), std::string::npos) << message;
  EXPECT_NE(message.find("not a video file"), std::string::npos) << message;
}

TEST(Video, ATruncatedVideoLosesItsLastFramesNotTheOthers) {
  const fs::path folder = scratch("truncated") / "cam";
  makeCameraVideo(folder, 60, "container", "--fragmented --keyint 10");
  const fs::path video = folder / "video.mp4";
  fs::resize_file(video, fs::file_size(video) * 2 / 3);
  const VideoProbe probe = probeVideo(video, true);
  EXPECT_GT(probe.frame_count, 20);
  EXPECT_LT(probe.frame_count, 60);
  // Every frame before the last group of pictures decodes as itself; in the
  // last one, cut short, frames may be lost or come out concealed by the
  // decoder (doc/formats.md, "Video files").
  const std::int64_t whole = probe.frame_count / 10 * 10 - 10;
  VideoDecoder decoder(video);
  for (std::int64_t i = 0; i < probe.frame_count; ++i) {
    const cv::Mat grey = decoder.frame(i, false);
    if (i >= whole) continue;
    ASSERT_FALSE(grey.empty()) << i;
    EXPECT_EQ(readBarCode(grey), i);
  }
  EXPECT_TRUE(decoder.frame(probe.frame_count, false).empty());
}

TEST(Video, WritersKeepTheVideoInAFolderAndExtractPngForARawlog) {
  const fs::path site = makeVideoDataset("writers", 8, "container");
  const fs::path out = site.parent_path() / "copy";
  ConvertOptions options;
  options.from = site;
  options.to = out;
  convertData(options, ProgressReporter());
  EXPECT_TRUE(fs::exists(out / "cameras/cam00/video.mp4"));
  EXPECT_TRUE(fs::exists(out / "cameras/cam00/video.csv"));
  EXPECT_FALSE(fs::exists(out / "cameras/cam00/frames.csv"));
  const ReadBack original = readFrames(site), copy = readFrames(out);
  ASSERT_EQ(copy.frames.size(), original.frames.size());
  for (size_t i = 0; i < copy.frames.size(); ++i) {
    EXPECT_EQ(copy.frames[i].t, original.frames[i].t);
    EXPECT_EQ(copy.frames[i].video_frame, original.frames[i].video_frame);
  }
  options.to = site.parent_path() / "extracted.rawlog";
  convertData(options, ProgressReporter());
  const ReadBack rawlog = readFrames(options.to);
  ASSERT_EQ(rawlog.frames.size(), 8u);
  FrameDecoder decoder;
  for (size_t i = 0; i < rawlog.frames.size(); ++i) {
    EXPECT_FALSE(isVideoFrame(rawlog.frames[i]));
    EXPECT_EQ(rawlog.frames[i].t, original.frames[i].t);
    EXPECT_EQ(readBarCode(decoder.decode(rawlog.frames[i], FrameColour::kGrey)),
              static_cast<int>(i));
  }
}

TEST(Video, ConvertAddsAVideoToADatasetTimedByItsStart) {
  const fs::path site = makeVideoDataset("convert_video", 6, "container");
  const fs::path video = site.parent_path() / "cam09.mp4";
  fs::copy_file(site / "cameras/cam00/video.mp4", video);
  ConvertOptions options;
  options.from = site;
  options.to = site.parent_path() / "with_cam09";
  options.videos.push_back(
      {"cam09", video, "", TimeNs{77}, site / "cameras/cam00/calibration.yaml"});
  const ConvertSummary summary = convertData(options, ProgressReporter());
  EXPECT_EQ(summary.records.at("image"), 12);
  const ReadBack read = readFrames(options.to);
  std::vector<TimeNs> cam09;
  for (const ImageFrame& f : read.frames)
    if (f.sensor == "cam09") cam09.push_back(f.t);
  ASSERT_EQ(cam09.size(), 6u);
  EXPECT_EQ(cam09[0], 77);
  EXPECT_EQ(cam09[5], 77 + 5 * kPeriod);
  // A camera the input lacks needs its calibration.
  options.videos[0].calibration.clear();
  options.to = site.parent_path() / "without_calibration";
  try {
    convertData(options, ProgressReporter());
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--calibration cam09=FILE"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(fs::exists(options.to));
}

/// Runs ffmpeg on `in` (quietly); false when it fails.
bool ffmpeg(const fs::path& in, const std::string& arguments, const fs::path& out,
            const std::string& input_options = "") {
  const std::string command = "ffmpeg -v error -y " + input_options + " -i '" + in.string() + "' " +
                              arguments + " '" + out.string() + "'";
  return std::system(command.c_str()) == 0;
}

TEST(Video, FramesFarAheadAreReachedBySeeking) {
  const fs::path folder = scratch("far") / "cam";
  makeCameraVideo(folder, 400, "container", "--keyint 50");
  VideoDecoder decoder(folder / "video.mp4");
  for (const int i : {0, 390, 5, 350, 399, 42, 42, 41}) {
    const cv::Mat grey = decoder.frame(i, false);
    ASSERT_FALSE(grey.empty()) << i;
    EXPECT_EQ(readBarCode(grey), i);
  }
}

// The key frames are listed, and a jump to a frame after a key frame ahead
// starts there: key frame to key frame, the same pixels as decoding every frame.
TEST(Video, KeyFramesAreListedAndAJumpToOneDecodesItAlone) {
  const fs::path folder = scratch("keys") / "cam";
  makeCameraVideo(folder, 100, "container", "--keyint 10");
  VideoDecoder every(folder / "video.mp4");
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 100; ++i) frames.push_back(every.frame(i, false));
  VideoDecoder jumping(folder / "video.mp4");
  const std::vector<std::int64_t>& keys = jumping.keyFrames();
  // At most 10 apart (libx264 may add one at a scene cut).
  ASSERT_GE(keys.size(), 10u);
  EXPECT_EQ(keys.front(), 0);
  for (std::size_t k = 1; k < keys.size(); ++k) EXPECT_LE(keys[k] - keys[k - 1], 10);
  std::vector<std::int64_t> wanted;
  for (std::size_t k = 0; k < keys.size(); k += 2) wanted.push_back(keys[k]);
  for (const std::int64_t i : {31, 95, 20, 90}) wanted.push_back(i);
  for (const std::int64_t i : wanted) {
    const cv::Mat grey = jumping.frame(i, false);
    ASSERT_FALSE(grey.empty()) << i;
    EXPECT_EQ(readBarCode(grey), i);
    EXPECT_EQ(cv::norm(grey, frames[static_cast<std::size_t>(i)], cv::NORM_INF), 0.0) << i;
  }
}

// What a jump costs, at 30 Hz on a microsecond clock (intervals of 33,334,
// 33,333 and 33,333 us, as the simulator's cameras; B-frames make the
// demuxer shift decoding times by the first frames' 66,667 us, a later key
// frame's own shift is 66,666): a jump to a key frame ahead starts decoding
// at that key frame, not at the one before it; the frame before the next
// key frame decodes its references, not the B-frames shown before it that
// nothing refers to; every frame still comes out exact.
TEST(Video, AJumpDecodesOnlyWhatTheFrameNeeds) {
  const fs::path folder = scratch("jump_cost") / "cam";
  // Key frames every 30 frames only; up to 3 B-frames in a row (libx264's
  // pyramid makes the middle one a reference, the others not).
  makeCameraVideo(folder, 120, "container", "--keyint 30 --bframes 3 --no-scene-cuts",
                  [](int i) -> TimeNs { return (i * 100'000LL + 2) / 3 * 1000; });
  VideoDecoder every(folder / "video.mp4");
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 120; ++i) frames.push_back(every.frame(i, false));
  EXPECT_EQ(every.framesOutput(), 120);
  VideoDecoder jumping(folder / "video.mp4");
  const std::vector<std::int64_t> keys = jumping.keyFrames();
  ASSERT_EQ(keys, (std::vector<std::int64_t>{0, 30, 60, 90}));
  for (const std::int64_t key : keys) {
    const std::int64_t before = jumping.framesOutput();
    const cv::Mat grey = jumping.frame(key, false);
    ASSERT_FALSE(grey.empty()) << key;
    EXPECT_EQ(cv::norm(grey, frames[static_cast<std::size_t>(key)], cv::NORM_INF), 0.0) << key;
    EXPECT_EQ(jumping.framesOutput() - before, 1) << "jump to key frame " << key;
  }
  const std::int64_t before = jumping.framesOutput();
  const cv::Mat last = jumping.frame(119, false);
  ASSERT_FALSE(last.empty());
  EXPECT_EQ(cv::norm(last, frames[119], cv::NORM_INF), 0.0);
  EXPECT_LT(jumping.framesOutput() - before, 119 - 90) << "B-frames decoded on the way";
  // The frames after the one asked for are decoded: the next is exact.
  const cv::Mat after = jumping.frame(45, false);
  ASSERT_FALSE(after.empty());
  for (std::int64_t i = 46; i < 54; ++i) {
    const cv::Mat grey = jumping.frame(i, false);
    ASSERT_FALSE(grey.empty()) << i;
    EXPECT_EQ(cv::norm(grey, frames[static_cast<std::size_t>(i)], cv::NORM_INF), 0.0) << i;
  }
  EXPECT_EQ(cv::norm(after, frames[45], cv::NORM_INF), 0.0);
}

// A key frame's preview skips the loop filter: close to the frame, not it
// (a strongly compressed, textured video, where deblocking moves pixels);
// the frames decoded after a preview are exactly those decoded without one.
TEST(Video, AKeyFramesPreviewIsCloseAndTheFramesAfterItAreExact) {
  const fs::path folder = scratch("preview") / "cam";
  fs::create_directories(folder / "frames");
  std::ofstream csv(folder / "frames.csv");
  csv << "timestamp_ns,file\n";
  cv::Mat texture(kHeight * 2, kWidth * 2, CV_8UC1);
  cv::theRNG().state = 5;
  cv::randu(texture, 40, 220);
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1.5);
  for (int i = 0; i < 60; ++i) {
    cv::Mat image = barCode(i);
    // The texture slides over the bar code's lowest quarter (it is read
    // at half height): every frame changes.
    texture(cv::Rect(i % kWidth, 0, kWidth, kHeight / 4))
        .copyTo(image.rowRange(kHeight * 3 / 4, kHeight));
    const std::string name = "frames/" + std::to_string(i) + ".png";
    cv::imwrite((folder / name).string(), image);
    csv << kStart + i * kPeriod << "," << name << "\n";
  }
  csv.close();
  const std::string script = std::string(LOOKBOTH_SHARE_DIR) + "/../../scripts/frames_to_video.py";
  const std::string command =
      "python3 '" + script + "' '" + folder.string() + "' --timing container --crf 36 --keyint 20";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  VideoDecoder every(folder / "video.mp4");
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 60; ++i) frames.push_back(every.frame(i, false));
  VideoDecoder previewing(folder / "video.mp4");
  const std::vector<std::int64_t> keys = previewing.keyFrames();
  ASSERT_GE(keys.size(), 3u);
  double differs = 0;
  for (const std::int64_t k : keys) {
    const auto at = static_cast<std::size_t>(k);
    const cv::Mat preview = previewing.keyFramePreview(k);
    ASSERT_FALSE(preview.empty()) << k;
    EXPECT_EQ(readBarCode(preview), k);
    EXPECT_LT(cv::norm(preview, frames[at], cv::NORM_L1) / static_cast<double>(preview.total()),
              3.0)
        << k;
    differs += cv::norm(preview, frames[at], cv::NORM_INF);
    // The frames after it, then the frame itself, exact; on every other
    // key frame the frame itself first (not the preview kept for a repeat).
    const std::vector<std::size_t> order = k % 2 == 0
                                               ? std::vector<std::size_t>{at, at + 1, at + 2}
                                               : std::vector<std::size_t>{at + 1, at + 2, at};
    for (const std::size_t i : order) {
      if (i >= frames.size()) continue;
      const cv::Mat exact = previewing.frame(static_cast<std::int64_t>(i), false);
      ASSERT_FALSE(exact.empty()) << i;
      EXPECT_EQ(cv::norm(exact, frames[i], cv::NORM_INF), 0.0)
          << "frame " << i << " after key " << k;
    }
  }
  EXPECT_GT(differs, 0.0);  // the loop filter was skipped
  // A frame that is not a key frame comes exact.
  std::int64_t other = keys[1] + 1;
  while (std::binary_search(keys.begin(), keys.end(), other)) ++other;
  ASSERT_LT(other, 60);
  EXPECT_EQ(cv::norm(previewing.keyFramePreview(other), frames[static_cast<std::size_t>(other)],
                     cv::NORM_INF),
            0.0);
}

TEST(Video, AClipCutWithoutReencodingStartsAtItsFirstShownFrame) {
  // Cut at 0.5 s without re-encoding: the container keeps the key frame
  // before the cut and an edit list that hides the frames before 0.5 s.
  const fs::path folder = scratch("cut") / "cam";
  makeCameraVideo(folder, 50, "container", "--keyint 10");
  const fs::path cut = folder / "cut.mp4";
  ASSERT_TRUE(ffmpeg(folder / "video.mp4", "-c copy", cut, "-ss 0.5"));
  const VideoProbe probe = probeVideo(cut, true);
  ASSERT_GE(probe.frame_count, 30);
  ASSERT_LE(probe.frame_count, 38);  // the packets before 0.5 s are not frames
  ASSERT_EQ(probe.frame_offsets_ns.size(), static_cast<size_t>(probe.frame_count));
  VideoDecoder decoder(cut);
  const int first = readBarCode(decoder.frame(0, false));
  EXPECT_GE(first, 10);
  for (std::int64_t i = 0; i < probe.frame_count; ++i) {
    const cv::Mat grey = decoder.frame(i, false);
    ASSERT_FALSE(grey.empty()) << i;
    EXPECT_EQ(readBarCode(grey), first + i);
    EXPECT_EQ(probe.frame_offsets_ns[static_cast<size_t>(i)], i * kPeriod) << i;
  }
}

TEST(Video, MatroskaAndRawStreams) {
  const fs::path site = makeVideoDataset("containers", 12, "container");
  const fs::path folder = site / "cameras/cam00";
  // Matroska: no frame count in the header; a sidecar's rows are checked against the frames.
  ASSERT_TRUE(ffmpeg(folder / "video.mp4", "-c copy", folder / "video.mkv"));
  fs::remove(folder / "video.mp4");
  EXPECT_EQ(probeVideo(folder / "video.mkv", false).frame_count, -1);
  std::ofstream(folder / "video.csv") << "timestamp_ns,frame\n10,0\n20,11\n30,12\n";
  ReadBack read = readFrames(site);
  ASSERT_EQ(read.frames.size(), 2u);
  ASSERT_EQ(read.issues.size(), 1u);
  EXPECT_NE(read.issues[0].message.find("frame 12 but 'video.mkv' has 12 frames"),
            std::string::npos)
      << read.issues[0].message;
  FrameDecoder decoder;
  EXPECT_EQ(readBarCode(decoder.decode(read.frames[1], FrameColour::kGrey)), 11);
  // A raw H.264 stream has no timestamps: a sidecar times it, video.yaml cannot.
  ASSERT_TRUE(ffmpeg(folder / "video.mkv", "-c copy -f h264", folder / "video.h264"));
  fs::remove(folder / "video.mkv");
  EXPECT_TRUE(probeVideo(folder / "video.h264", true).frame_offsets_ns.empty());
  read = readFrames(site);
  ASSERT_EQ(read.frames.size(), 2u);  // frames counted by demultiplexing: 12 again
  // Back from frame 11 to frame 0: without timestamps, by decoding from the start.
  EXPECT_EQ(readBarCode(decoder.decode(read.frames[1], FrameColour::kGrey)), 11);
  EXPECT_EQ(readBarCode(decoder.decode(read.frames[0], FrameColour::kGrey)), 0);
  fs::remove(folder / "video.csv");
  try {
    readFrames(site);
    ADD_FAILURE() << "a raw stream timed by video.yaml";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no frame timestamps"), std::string::npos) << e.what();
  }
}

TEST(Video, AVideoRewrittenInPlaceIsOpenedAgain) {
  const fs::path folder = scratch("rewritten") / "cam";
  makeCameraVideo(folder, 10, "container");
  ImageFrame frame;
  frame.video_file = folder / "video.mp4";
  frame.video_frame = 9;
  FrameDecoder decoder;
  EXPECT_EQ(readBarCode(decoder.decode(frame, FrameColour::kGrey)), 9);
  const fs::path other = scratch("rewritten_other") / "cam";
  makeCameraVideo(other, 30, "container", "--drop 0,1,2,3,4,5,6,7,8,9");
  fs::copy_file(other / "video.mp4", frame.video_file, fs::copy_options::overwrite_existing);
  EXPECT_EQ(readBarCode(decoder.decode(frame, FrameColour::kGrey)), 19);
}

TEST(Video, FrameTimingCountsGapsAndRepeats) {
  const std::vector<TimeNs> times = {0, 100, 200, 500, 600, 600, 700, 1000};
  const FrameTiming timing = analyseFrameTimes(times);
  EXPECT_DOUBLE_EQ(timing.period_ns, 100);
  EXPECT_EQ(timing.gaps, 2);
  EXPECT_EQ(timing.dropped, 4);
  EXPECT_EQ(timing.repeated, 1);
  EXPECT_EQ(timing.longest_gap_ns, 300);
  EXPECT_EQ(timing.longest_gap_at, 200);
  EXPECT_TRUE(analyseFrameTimes({0, 100, 200}).describeGaps().empty());
}

// The encoder, read back by the decoder and by the probe: every frame in
// place and on time, the key frames where asked, the grey levels kept.
TEST(VideoEncoder, FramesComeBackInOrderOnTimeWithKeyFramesAtTheInterval) {
  const fs::path file = scratch("encode") / "video.mp4";
  VideoEncodeOptions options;
  options.crf = 10;
  options.key_frame_interval = 8;
  {
    VideoEncoder encoder(file, kWidth, kHeight, options);
    for (int i = 0; i < 40; ++i) encoder.write(barCode(i), 1000 + i * 33'333 + (i == 20 ? 5 : 0));
    EXPECT_FALSE(fs::exists(file));  // only the partial file until finished
    encoder.finish();
    EXPECT_EQ(encoder.frames(), 40);
  }
  ASSERT_TRUE(fs::exists(file));
  EXPECT_FALSE(fs::exists(file.string() + ".partial"));
  const VideoProbe probe = probeVideo(file, true);
  EXPECT_EQ(probe.codec, "h264");
  EXPECT_EQ(probe.frame_count, 40);
  ASSERT_EQ(probe.frame_offsets_ns.size(), 40u);
  for (int i = 0; i < 40; ++i) {
    EXPECT_EQ(probe.frame_offsets_ns[static_cast<size_t>(i)],
              (i * 33'333 + (i == 20 ? 5 : 0)) * 1000)
        << i;
  }
  VideoDecoder decoder(file);
  const std::vector<std::int64_t> expected_keys = {0, 8, 16, 24, 32};
  EXPECT_EQ(decoder.keyFrames(), expected_keys);
  for (const int i : {0, 1, 17, 39, 8, 3}) EXPECT_EQ(readBarCode(decoder.frame(i, false)), i);
}

TEST(VideoEncoder, GreyLevelsSurviveTheVideoRange) {
  const fs::path file = scratch("encode_grey") / "video.mkv";
  cv::Mat ramp(kHeight, kWidth, CV_8UC1);
  for (int v = 0; v < kHeight; ++v) {
    for (int u = 0; u < kWidth; ++u)
      ramp.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(v * 2 + (u > 80 ? 10 : 0));
  }
  VideoEncodeOptions options;
  options.crf = 0;  // lossless: what is left is the range's rounding
  VideoEncoder encoder(file, kWidth, kHeight, options);
  encoder.write(ramp, 0);
  encoder.write(ramp, 40'000);
  encoder.finish();
  VideoDecoder decoder(file);
  const cv::Mat back = decoder.frame(1, false);
  ASSERT_FALSE(back.empty());
  EXPECT_LE(cv::norm(back, ramp, cv::NORM_INF), 1.0);
}

TEST(VideoEncoder, OtherEncodersWriteWhatTheDecoderReads) {
  const fs::path file = scratch("encode_mpeg4") / "video.mkv";
  VideoEncodeOptions options;
  options.codec = "mpeg4";
  options.key_frame_interval = 5;
  {
    VideoEncoder encoder(file, kWidth, kHeight, options);
    for (int i = 0; i < 12; ++i) encoder.write(barCode(i), i * 40'000);
    encoder.finish();
  }
  EXPECT_EQ(probeVideo(file, false).codec, "mpeg4");
  VideoDecoder decoder(file);
  for (int i = 0; i < 12; ++i) EXPECT_EQ(readBarCode(decoder.frame(i, false)), i);
}

TEST(VideoEncoder, BadInputNamesTheFileAndLeavesNothingBehind) {
  const fs::path dir = scratch("encode_bad");
  auto message = [](const std::function<void()>& action) {
    try {
      action();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  VideoEncodeOptions options;
  EXPECT_NE(message([&] { VideoEncoder(dir / "odd.mp4", 161, 120, options); }).find("even width"),
            std::string::npos);
  EXPECT_NE(message([&] {
              VideoEncoder(dir / "v.nosuchformat", kWidth, kHeight, options);
            }).find("v.nosuchformat"),
            std::string::npos);
  options.codec = "nosuchcodec";
  EXPECT_NE(
      message([&] { VideoEncoder(dir / "v.mp4", kWidth, kHeight, options); }).find("nosuchcodec"),
      std::string::npos);
  options = VideoEncodeOptions();
  options.key_frame_interval = 0;
  EXPECT_NE(message([&] {
              VideoEncoder(dir / "v.mp4", kWidth, kHeight, options);
            }).find("key_frame_interval"),
            std::string::npos);
  options = VideoEncodeOptions();
  {
    VideoEncoder encoder(dir / "late.mp4", kWidth, kHeight, options);
    encoder.write(barCode(0), 100);
    const std::string late = message([&] { encoder.write(barCode(1), 100); });
    EXPECT_NE(late.find("does not follow"), std::string::npos) << late;
    EXPECT_NE(late.find("late.mp4"), std::string::npos) << late;
    const std::string small = message([&] { encoder.write(cv::Mat(10, 10, CV_8UC1), 200); });
    EXPECT_NE(small.find("not 8-bit grey of 160x120"), std::string::npos) << small;
  }  // never finished: nothing left
  EXPECT_TRUE(fs::is_empty(dir));
}

}  // namespace
}  // namespace lookboth
