// Runs one long job at a time on a worker thread, for the desktop app: the
// same jobs the command line runs (simulate, open, detect, register...),
// with the same ProgressReporter. The callbacks run on the worker thread; a
// GUI forwards them to its own thread (wxEvtHandler::CallAfter).
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "lookboth/core/progress.h"

namespace lookboth::studio {

enum class JobStatus { kSucceeded, kStopped, kFailed };
const char* jobStatusName(JobStatus status);

struct JobResult {
  std::string name;  ///< The job's name ("simulate small", "register"...).
  JobStatus status = JobStatus::kSucceeded;
  std::string message;  ///< The error for kFailed (lookboth::Error text), else empty.
  double seconds = 0;   ///< Wall time.
};

class JobRunner {
 public:
  using Job = std::function<void(const ProgressReporter&)>;
  using DoneCallback = std::function<void(const JobResult&)>;

  JobRunner() = default;
  /// Stops a running job and waits for it.
  ~JobRunner();
  JobRunner(const JobRunner&) = delete;
  JobRunner& operator=(const JobRunner&) = delete;

  /// Starts `job` on a new worker thread. Returns false (and does nothing)
  /// while another job runs. `on_progress` and `on_done` run on the worker.
  bool start(const std::string& name, Job job, ProgressCallback on_progress, DoneCallback on_done);
  bool running() const { return running_.load(); }
  /// Asks the running job to stop at its next check (returns at once).
  void requestStop();
  /// Waits for the running job (if any) to end.
  void wait();

 private:
  std::thread worker_;
  std::atomic<bool> running_{false};
  std::mutex mutex_;
  ProgressReporter reporter_;
};

}  // namespace lookboth::studio
