#include "lookboth/studio/job_runner.h"

#include <chrono>

#include "lookboth/core/error.h"

namespace lookboth::studio {

const char* jobStatusName(JobStatus status) {
  switch (status) {
    case JobStatus::kSucceeded:
      return "succeeded";
    case JobStatus::kStopped:
      return "stopped";
    case JobStatus::kFailed:
      return "failed";
  }
  return "?";
}

JobRunner::~JobRunner() {
  requestStop();
  wait();
}

bool JobRunner::start(const std::string& name, Job job, ProgressCallback on_progress,
                      DoneCallback on_done) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (running_.load()) return false;
  if (worker_.joinable()) worker_.join();
  running_.store(true);
  reporter_ = ProgressReporter(std::move(on_progress));
  const ProgressReporter reporter = reporter_;
  worker_ =
      std::thread([this, name, job = std::move(job), on_done = std::move(on_done), reporter]() {
        JobResult result;
        result.name = name;
        const auto start = std::chrono::steady_clock::now();
        try {
          job(reporter);
          result.status = JobStatus::kSucceeded;
        } catch (const StopRequested&) {
          result.status = JobStatus::kStopped;
        } catch (const Error& e) {
          result.status = JobStatus::kFailed;
          result.message = e.what();
        } catch (const std::exception& e) {
          result.status = JobStatus::kFailed;
          result.message = std::string("internal error: ") + e.what();
        }
        result.seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        running_.store(false);
        if (on_done) on_done(result);
      });
  return true;
}

void JobRunner::requestStop() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (running_.load()) reporter_.requestStop();
}

void JobRunner::wait() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (worker_.joinable()) worker_.join();
}

}  // namespace lookboth::studio
