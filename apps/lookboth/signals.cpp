#include "signals.h"

#include <csignal>

namespace lookboth::app {
namespace {

std::atomic<bool>* g_stop_flag = nullptr;

extern "C" void onStopSignal(int signal) {
  if (g_stop_flag && !g_stop_flag->load()) {
    g_stop_flag->store(true);
    return;
  }
  std::signal(signal, SIG_DFL);
  std::raise(signal);
}

}  // namespace

StopOnSignal::StopOnSignal(const ProgressReporter& reporter) : flag_(reporter.stopFlag()) {
  g_stop_flag = flag_.get();
  std::signal(SIGINT, onStopSignal);
  std::signal(SIGTERM, onStopSignal);
}

StopOnSignal::~StopOnSignal() {
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  g_stop_flag = nullptr;
}

}  // namespace lookboth::app
