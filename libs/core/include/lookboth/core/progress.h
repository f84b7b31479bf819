// Progress reporting and cooperative cancellation for long jobs. One
// mechanism for the command line (a bar on a terminal, plain lines
// otherwise) and the desktop app (a worker thread polls nothing: it receives
// callbacks and sets the stop flag).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>

namespace lookboth {

/// Thrown by `ProgressReporter::checkStop()` when the user asked to stop.
/// Jobs let it propagate after leaving their outputs as they were (temporary
/// files removed, nothing half-written under a final name).
class StopRequested : public std::exception {
 public:
  const char* what() const noexcept override { return "stopped at the user's request"; }
};

/// What a job tells its observer: the stage it is in, how far along it is.
struct ProgressEvent {
  std::string stage;       ///< e.g. "convert", "detect: cam03".
  std::int64_t done = 0;   ///< Items done so far.
  std::int64_t total = 0;  ///< Items in all; 0 when unknown.
  std::string message;     ///< Optional detail for the user.
};

using ProgressCallback = std::function<void(const ProgressEvent&)>;

/// Passed by value into long jobs. Cheap to copy; all copies share one stop flag.
class ProgressReporter {
 public:
  ProgressReporter() : stop_(std::make_shared<std::atomic<bool>>(false)) {}
  explicit ProgressReporter(ProgressCallback callback)
      : callback_(std::move(callback)), stop_(std::make_shared<std::atomic<bool>>(false)) {}

  /// Reports progress (rate-limited by the observer, not here).
  void report(const ProgressEvent& event) const {
    if (callback_) callback_(event);
  }
  void report(const std::string& stage, std::int64_t done, std::int64_t total,
              const std::string& message = "") const {
    report(ProgressEvent{stage, done, total, message});
  }

  /// Asks the job to stop at its next check (thread-safe, e.g. from a signal
  /// handler's flag watcher or the GUI thread).
  void requestStop() const { stop_->store(true); }
  bool stopRequested() const { return stop_->load(); }
  /// Throws StopRequested when a stop was requested.
  void checkStop() const {
    if (stopRequested()) throw StopRequested();
  }
  /// A reporter that shares this one's stop flag and reports to `callback`
  /// instead (e.g. to merge the reports of two jobs running at once).
  ProgressReporter withCallback(ProgressCallback callback) const {
    ProgressReporter other(*this);
    other.callback_ = std::move(callback);
    return other;
  }
  /// The shared flag, for whoever must set it (e.g. a SIGINT handler).
  std::shared_ptr<std::atomic<bool>> stopFlag() const { return stop_; }

 private:
  ProgressCallback callback_;
  std::shared_ptr<std::atomic<bool>> stop_;
};

/// A ProgressCallback that draws a bar on a terminal ("\r" redraws, at most
/// 10 times a second) or prints plain lines otherwise (at most one per 5 %
/// step or per 10 s, plus the first and last of each stage).
ProgressCallback makeConsoleProgress(std::FILE* out, bool is_terminal);
/// The same on stderr, as a bar when stderr is a terminal.
ProgressCallback makeConsoleProgress();

}  // namespace lookboth
