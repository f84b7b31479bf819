// Detection and odometry at once. They read the same dataset and neither
// needs the other's result, so `register`'s detect step runs the odometry
// (its tracking thread and its decoding thread) beside detection's workers
// (FullPipelineOptions::overlap_steps); both results are written after both
// are done, so that nothing reads the dataset while it is replaced. The
// fisheye's blobs are searched in the frames the odometry decodes
// (BlobsBesideOdometry), each fisheye frame then decoded once for both, when
// that search is detection's own (finish() says when).
#pragma once

#include <atomic>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "lookboth/core/bounded_queue.h"
#include "lookboth/core/progress.h"
#include "lookboth/detect/detect_dataset.h"
#include "lookboth/vo/run.h"

namespace lookboth {

/// One progress line for two jobs on two threads: while both run,
/// detection's counts with the odometry's share in the message; the
/// odometry's own once detection is done. Reports are serialised: a console
/// bar or the desktop app's callback is never called from two threads at once.
class JointProgress : public std::enable_shared_from_this<JointProgress> {
 public:
  explicit JointProgress(ProgressReporter user) : user_(std::move(user)) {}
  /// Detection's reporter: the user's stop flag.
  ProgressReporter detection();
  /// The odometry's reporter: its own stop flag, raised by the user's or by cancel().
  ProgressReporter odometry();
  void detectionDone();
  void odometryDone();
  /// Stops the odometry (detection failed: its result is not wanted).
  void cancel() { odometry_stop_->store(true); }

 private:
  void fromDetection(const ProgressEvent& event);
  void fromOdometry(const ProgressEvent& event);

  ProgressReporter user_;
  ProgressReporter odometry_reporter_;
  std::shared_ptr<std::atomic<bool>> odometry_stop_ = odometry_reporter_.stopFlag();
  std::mutex mutex_;
  std::optional<ProgressEvent> odometry_last_;
  bool detecting_ = true;
  bool odometry_done_ = false;
};

/// `lookboth odometry` on a thread of its own, without writing the dataset;
/// wait() returns its summary (or rethrows its error), stopping it when
/// `progress` is asked to stop. Dropped unfinished (detection failed or was
/// stopped), it is stopped and joined.
class BackgroundOdometry {
 public:
  BackgroundOdometry(vo::OdometryRunOptions options, std::shared_ptr<JointProgress> progress);
  ~BackgroundOdometry();
  BackgroundOdometry(const BackgroundOdometry&) = delete;
  BackgroundOdometry& operator=(const BackgroundOdometry&) = delete;
  vo::OdometryRunSummary wait(const ProgressReporter& progress);

 private:
  std::shared_ptr<JointProgress> progress_;
  std::optional<vo::OdometryRunSummary> summary_;
  std::exception_ptr error_;
  std::atomic<bool> finished_{false};
  std::thread thread_;
};

/// The fisheye's blob search (FisheyeBlobSearch) on a thread of its own,
/// given the frames the odometry decodes (tap()): the odometry's decoding
/// thread hands each frame over (waiting only when 4 are not yet searched).
/// It must outlive the odometry run its tap is given to. Dropped unfinished
/// (the odometry was stopped), the frames not yet searched are dropped.
class BlobsBesideOdometry {
 public:
  BlobsBesideOdometry(const CameraSensor& fisheye, const DetectConfig& config);
  ~BlobsBesideOdometry();
  BlobsBesideOdometry(const BlobsBesideOdometry&) = delete;
  BlobsBesideOdometry& operator=(const BlobsBesideOdometry&) = delete;
  /// For vo::OdometryRunOptions::tap: the fisheye's frames that the search
  /// wants (blobs.max_rate_hz).
  vo::OdometryRunOptions::FrameTap tap();
  /// Once the odometry run is over, done or failed: waits for the frames
  /// handed over to be searched. The search when it is detection's own:
  /// every fisheye frame of the dataset offered, in time order, and
  /// searched; else nullptr, and detection searches the blobs itself.
  FisheyeBlobSearch* finish();

 private:
  void work();

  std::string label_;
  FisheyeBlobSearch search_;  ///< wants() on the odometry's thread, search() on ours.
  BoundedQueue<std::pair<ImageFrame, cv::Mat>> queue_{4};
  // The odometry's decoding thread's, read by finish() once it is joined.
  bool offered_ = false, in_order_ = true, read_all_ = false;
  TimeNs last_t_ = 0;
  std::atomic<bool> failed_{false};  ///< The search threw (ours), seen by the tap.
  std::atomic<bool> abandon_{false};
  std::thread thread_;
};

}  // namespace lookboth
