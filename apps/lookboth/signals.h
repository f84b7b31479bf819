// Ctrl-C (SIGINT) and SIGTERM ask the running job to stop cleanly through its
// ProgressReporter's stop flag; a second Ctrl-C kills the process.
#pragma once

#include "lookboth/core/progress.h"

namespace lookboth::app {

/// Routes SIGINT/SIGTERM to `reporter.requestStop()` for as long as the
/// returned guard lives.
class StopOnSignal {
 public:
  explicit StopOnSignal(const ProgressReporter& reporter);
  ~StopOnSignal();
  StopOnSignal(const StopOnSignal&) = delete;
  StopOnSignal& operator=(const StopOnSignal&) = delete;

 private:
  std::shared_ptr<std::atomic<bool>> flag_;
};

}  // namespace lookboth::app
