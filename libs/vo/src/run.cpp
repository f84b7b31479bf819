#include "lookboth/vo/run.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <thread>

#include "lookboth/core/bounded_queue.h"
#include "lookboth/core/error.h"
#include "lookboth/dataset/augment.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/dataset/frame_decoder.h"
#include "lookboth/dataset/image_header.h"
#include "lookboth/geometry/time.h"
#include "lookboth/geometry/tum.h"
#include "lookboth/vo/landmark_map.h"

namespace lookboth::vo {
namespace {

using Clock = std::chrono::steady_clock;
double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

struct DecodedFrame {
  TimeNs t = 0;
  cv::Mat image;  ///< Working resolution, 8-bit grey.
};

using FrameQueue = BoundedQueue<DecodedFrame>;

/// Refuses a frame whose size is not the calibration's: tracking it would
/// put features at pixels the camera does not have (and a huge one would be
/// decoded into gigabytes first). The header is read before decoding.
void checkFrameSize(const ImageFrame& frame, const Camera& camera, int width, int height) {
  if (width == camera.width() && height == camera.height()) return;
  throw Error(frameName(frame) + ": the image is " + std::to_string(width) + "x" +
              std::to_string(height) + ", the fisheye's calibration " +
              std::to_string(camera.width()) + "x" + std::to_string(camera.height()) +
              " (wrong calibration or wrong camera label?)");
}

cv::Mat decode(FrameDecoder& decoder, const ImageFrame& frame, const Camera& camera) {
  if (const std::optional<ImageSize> header = decoder.size(frame))
    checkFrameSize(frame, camera, header->width, header->height);
  const cv::Mat image = decoder.decode(frame, FrameColour::kGrey);
  if (image.empty())
    throw Error(frameName(frame) +
                ": cannot decode the fisheye frame at t=" + formatSeconds(frame.t));
  checkFrameSize(frame, camera, image.cols, image.rows);
  return image;
}

}  // namespace

std::string OdometryRunOptions::check() const {
  if (dataset.empty()) return "'dataset': missing";
  if (max_duration_s < 0) return "'max_duration_s': must not be negative";
  return odometry.check();
}

AugmentSummary addOdometryTrajectory(const std::filesystem::path& dataset,
                                     const std::filesystem::path& out, bool overwrite,
                                     const Trajectory& trajectory,
                                     const std::function<void(const DatasetIssue&)>& on_issue,
                                     const ProgressReporter& progress) {
  AugmentOptions augment;
  augment.input = dataset;
  augment.output = out;
  augment.overwrite = overwrite;
  augment.on_issue = on_issue;
  augment.drop = [](const Record& record) {
    const auto* pose = std::get_if<PoseSample>(&record);
    return pose && pose->label == kVoTrajectoryLabel;
  };
  Manifest updated = DatasetReader::open(dataset)->manifest();
  auto& list = updated.trajectories;
  list.erase(std::remove_if(list.begin(), list.end(),
                            [](const TrajectoryInfo& t) { return t.label == kVoTrajectoryLabel; }),
             list.end());
  list.push_back(TrajectoryInfo{kVoTrajectoryLabel, false, kVoTrajectoryDescription});
  augment.manifest = updated;
  std::vector<Record> added;
  for (const StampedPose& p : trajectory.samples())
    added.emplace_back(PoseSample{p.t, kVoTrajectoryLabel, p.world_from_body});
  return augmentDataset(augment, std::move(added), progress);
}

OdometryRunSummary runOdometry(const OdometryRunOptions& options,
                               const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) throw Error("odometry: " + why);
  const Clock::time_point start = Clock::now();
  if (!options.tum_out.empty() && !options.overwrite && std::filesystem::exists(options.tum_out))
    throw Error(options.tum_out.string() + ": already exists (use --overwrite)");
  if (!options.map_out.empty()) {
    landmarkMapFormatOf(options.map_out);  // An unknown extension fails now, not after the run.
    if (!options.overwrite && std::filesystem::exists(options.map_out))
      throw Error(options.map_out.string() + ": already exists (use --overwrite)");
  }
  if (options.write_dataset && !options.out.empty() && !options.overwrite &&
      std::filesystem::exists(options.out))
    throw Error(options.out.string() + ": already exists (use --overwrite)");

  auto reader = DatasetReader::open(options.dataset);
  const Manifest manifest = reader->manifest();
  const CameraSensor* sensor =
      options.camera.empty() ? manifest.fisheye() : manifest.findCamera(options.camera);
  if (!sensor)
    throw Error(
        options.dataset.string() + ": no camera " +
        (options.camera.empty() ? std::string("with role fisheye") : "'" + options.camera + "'"));
  if (!sensor->camera)
    throw Error(options.dataset.string() + ": camera '" + sensor->label + "' has no calibration");
  const Camera camera = *sensor->camera;
  const std::string label = sensor->label;
  const int factor = VisualOdometry::downscaleFactor(camera.width(), options.odometry);

  // OpenCV's own worker threads off: the two threads here are the design
  // (decoding beside tracking), results and CPU timings stay per thread.
  struct OpenCvThreads {
    explicit OpenCvThreads(bool on) : limit(on) {
      if (limit) cv::setNumThreads(1);
    }
    ~OpenCvThreads() {
      if (limit) cv::setNumThreads(previous);
    }
    bool limit;
    int previous = cv::getNumThreads();
  } opencv_threads(options.limit_opencv_threads);

  OdometryRunSummary summary;
  summary.camera = label;
  summary.working_width = camera.width() / factor;
  summary.working_height = camera.height() / factor;
  VisualOdometry odometry(camera, options.odometry);

  // Reading and decoding on a second thread; ground truth collected there too.
  FrameQueue queue(8);
  std::vector<StampedPose> ground_truth;
  std::int64_t expected = reader->expectedCount();
  double decode_seconds = 0;
  std::atomic<std::int64_t> records_read{0};
  std::thread producer([&] {
    try {
      std::optional<TimeNs> first;
      FrameDecoder decoder;
      RateLimiter rate(options.odometry.max_rate_hz);
      bool stopped = false, cut = false;  // the tap's frames are then not all offered
      while (auto record = reader->next()) {
        ++records_read;
        if ((stopped = progress.stopRequested())) break;
        if (const auto* pose = std::get_if<PoseSample>(&*record)) {
          if (pose->label == "ground_truth")
            ground_truth.push_back({pose->t, pose->world_from_body});
          continue;
        }
        const auto* frame = std::get_if<ImageFrame>(&*record);
        if (!frame || frame->sensor != label) continue;
        if (!first) first = frame->t;
        if (options.max_duration_s > 0 && frame->t - *first > secondsToNs(options.max_duration_s)) {
          cut = true;
          continue;
        }
        const bool for_odometry = rate.keep(frame->t);
        const bool for_tap = options.tap.wants && options.tap.wants(*frame);
        if (!for_odometry && !for_tap) continue;
        const double t0 = threadCpuSeconds();
        const cv::Mat image = decode(decoder, *frame, camera);
        DecodedFrame decoded;
        if (for_odometry) decoded = {frame->t, VisualOdometry::prepareImage(image, factor)};
        decode_seconds += threadCpuSeconds() - t0;
        if (for_tap) options.tap.take(*frame, image);
        if (for_odometry && !queue.push(std::move(decoded))) {
          stopped = true;
          break;
        }
      }
      if (!stopped && !cut && options.tap.read_all) options.tap.read_all();
      queue.close();
    } catch (...) {
      queue.close(std::current_exception());
    }
  });

  std::optional<TimeNs> last_t;
  try {
    while (auto frame = queue.pop()) {
      progress.checkStop();
      if (last_t && frame->t <= *last_t) continue;  // Duplicated or out-of-order stamp.
      last_t = frame->t;
      const double t0 = threadCpuSeconds();
      odometry.processFrame(frame->t, frame->image);
      summary.track_seconds += threadCpuSeconds() - t0;
      const OdometryStatistics& s = odometry.statistics();
      if (odometry.statistics().frames % 10 != 1) continue;
      progress.report("odometry", records_read.load(), expected,
                      std::to_string(s.keyframes) + " keyframes, " +
                          std::to_string(s.loop_closures) + " loops, " +
                          std::to_string(s.tracking_losses) + " losses");
    }
  } catch (...) {
    queue.cancel();
    producer.join();
    throw;
  }
  producer.join();
  if (std::exception_ptr error = queue.error()) std::rethrow_exception(error);
  reader.reset();  // The dataset may be replaced below.
  progress.checkStop();
  summary.decode_seconds = decode_seconds;

  const double t_finish = threadCpuSeconds();
  progress.report("odometry: global adjustment", 0, 0);
  summary.result = odometry.finish();
  summary.finish_seconds = threadCpuSeconds() - t_finish;
  progress.checkStop();

  if (summary.result.trajectory.empty())
    throw Error(
        options.dataset.string() + ": odometry: no fisheye frame got a pose (" +
        std::to_string(summary.result.statistics.frames) +
        " frames; the map never initialised: too few frames, too little motion or texture)");
  if (!ground_truth.empty()) {
    std::sort(ground_truth.begin(), ground_truth.end(),
              [](const StampedPose& a, const StampedPose& b) { return a.t < b.t; });
    Trajectory truth;
    for (const StampedPose& p : ground_truth) {
      if (truth.empty() || p.t > truth.endTime()) truth.append(p.t, p.world_from_body);
    }
    summary.ate = absoluteTrajectoryError(summary.result.trajectory, truth);
    summary.ate_keyframes = absoluteTrajectoryError(summary.result.keyframes, truth);
  }
  progress.checkStop();
  if (options.write_dataset) {
    const AugmentSummary written =
        addOdometryTrajectory(options.dataset, options.out, options.overwrite,
                              summary.result.trajectory, options.on_issue, progress);
    summary.records_written = written.added;
    summary.dataset_written = written.output;
  }
  if (!options.tum_out.empty()) writeTumFile(options.tum_out, summary.result.trajectory);
  if (!options.map_out.empty()) writeLandmarkMap(options.map_out, summary.result.landmarks);
  summary.wall_seconds = seconds(Clock::now() - start);
  return summary;
}

}  // namespace lookboth::vo
