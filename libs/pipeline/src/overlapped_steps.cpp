#include "overlapped_steps.h"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace lookboth {

ProgressReporter JointProgress::detection() {
  std::shared_ptr<JointProgress> self = shared_from_this();
  return user_.withCallback([self](const ProgressEvent& event) { self->fromDetection(event); });
}

ProgressReporter JointProgress::odometry() {
  std::shared_ptr<JointProgress> self = shared_from_this();
  return odometry_reporter_.withCallback(
      [self](const ProgressEvent& event) { self->fromOdometry(event); });
}

void JointProgress::odometryDone() {
  std::lock_guard<std::mutex> lock(mutex_);
  odometry_done_ = true;
}

void JointProgress::detectionDone() {
  std::lock_guard<std::mutex> lock(mutex_);
  detecting_ = false;
}

void JointProgress::fromDetection(const ProgressEvent& event) {
  if (user_.stopRequested()) odometry_stop_->store(true);
  std::lock_guard<std::mutex> lock(mutex_);
  ProgressEvent joint = event;
  if (odometry_done_) {
    joint.message = "odometry alongside: done";
  } else if (odometry_last_ && odometry_last_->total > 0) {
    const double share = 100.0 * static_cast<double>(odometry_last_->done) /
                         static_cast<double>(odometry_last_->total);
    joint.message = "odometry alongside: " + std::to_string(std::lround(share)) + " %";
  } else if (odometry_last_) {
    joint.message = "odometry alongside: " + odometry_last_->stage;
  }
  user_.report(joint);
}

void JointProgress::fromOdometry(const ProgressEvent& event) {
  if (user_.stopRequested()) odometry_stop_->store(true);
  std::lock_guard<std::mutex> lock(mutex_);
  odometry_last_ = event;
  if (!detecting_) user_.report(event);
}

BackgroundOdometry::BackgroundOdometry(vo::OdometryRunOptions options,
                                       std::shared_ptr<JointProgress> progress)
    : progress_(std::move(progress)) {
  options.write_dataset = false;
  const ProgressReporter reporter = progress_->odometry();
  thread_ = std::thread([this, options = std::move(options), reporter] {
    try {
      summary_ = vo::runOdometry(options, reporter);
    } catch (...) {
      error_ = std::current_exception();
    }
    progress_->odometryDone();
    finished_ = true;
  });
}

BackgroundOdometry::~BackgroundOdometry() {
  if (!thread_.joinable()) return;
  progress_->cancel();
  thread_.join();
}

vo::OdometryRunSummary BackgroundOdometry::wait(const ProgressReporter& progress) {
  while (!finished_.load()) {
    if (progress.stopRequested()) progress_->cancel();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (thread_.joinable()) thread_.join();
  if (error_) std::rethrow_exception(error_);
  return *summary_;
}

BlobsBesideOdometry::BlobsBesideOdometry(const CameraSensor& fisheye, const DetectConfig& config)
    : label_(fisheye.label), search_(fisheye, config), thread_([this] { work(); }) {}

BlobsBesideOdometry::~BlobsBesideOdometry() {
  abandon_ = true;
  queue_.cancel();
  queue_.close();
  if (thread_.joinable()) thread_.join();
}

void BlobsBesideOdometry::work() {
  try {
    while (std::optional<std::pair<ImageFrame, cv::Mat>> item = queue_.pop()) {
      if (!abandon_.load()) search_.search(item->first, item->second);
    }
  } catch (...) {
    // Not the odometry's failure: the search stops taking frames, and
    // finish() says it is incomplete (detection then searches on its own,
    // and reports the error if there is one).
    failed_ = true;
    queue_.cancel();
  }
}

vo::OdometryRunOptions::FrameTap BlobsBesideOdometry::tap() {
  vo::OdometryRunOptions::FrameTap tap;
  tap.wants = [this](const ImageFrame& frame) {
    if (frame.sensor != label_) return false;
    // Detection searches the frames in time order (the rate limit picks
    // them so); a dataset that is not is searched by detection itself.
    if (offered_ && frame.t < last_t_) in_order_ = false;
    offered_ = true;
    last_t_ = std::max(last_t_, frame.t);
    return !failed_.load() && search_.wants(frame.t);
  };
  tap.take = [this](const ImageFrame& frame, const cv::Mat& grey) {
    queue_.push({frame, grey});  // refused once the search failed: finish() tells
  };
  tap.read_all = [this] { read_all_ = true; };
  return tap;
}

FisheyeBlobSearch* BlobsBesideOdometry::finish() {
  queue_.close();
  if (thread_.joinable()) thread_.join();
  return read_all_ && in_order_ && !failed_.load() ? &search_ : nullptr;
}

}  // namespace lookboth
