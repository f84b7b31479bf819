#include "lookboth/core/progress.h"

#include <unistd.h>

#include <cstdio>
#include <mutex>

namespace lookboth {

ProgressCallback makeConsoleProgress() { return makeConsoleProgress(stderr, ::isatty(2) == 1); }

ProgressCallback makeConsoleProgress(std::FILE* out, bool is_terminal) {
  struct State {
    std::mutex mutex;
    bool tty = false;
    FILE* out = nullptr;
    std::string stage;
    std::chrono::steady_clock::time_point last_print{};
    int last_percent = -1;
    bool line_open = false;
  };
  auto state = std::make_shared<State>();
  state->tty = is_terminal;
  state->out = out;
  return [state](const ProgressEvent& event) {
    std::lock_guard<std::mutex> lock(state->mutex);
    const auto now = std::chrono::steady_clock::now();
    const bool finished = event.total > 0 && event.done >= event.total;
    const bool new_stage = event.stage != state->stage;
    const int percent =
        event.total > 0 ? static_cast<int>(100.0 * static_cast<double>(event.done) / event.total)
                        : -1;
    if (new_stage) {
      if (state->line_open) std::fputc('\n', state->out);
      state->line_open = false;
      state->stage = event.stage;
      state->last_percent = -1;
      state->last_print = {};
    }
    if (state->tty) {
      if (!finished && !new_stage && now - state->last_print < std::chrono::milliseconds(100))
        return;
      constexpr int kWidth = 30;
      std::string bar;
      if (event.total > 0) {
        const int filled = std::min(kWidth, kWidth * percent / 100);
        bar = "[" + std::string(filled, '#') + std::string(kWidth - filled, '.') + "] " +
              std::to_string(percent) + "% ";
      }
      std::fprintf(state->out, "\r\033[K%s %s%lld%s%s%s", event.stage.c_str(), bar.c_str(),
                   static_cast<long long>(event.done),
                   event.total > 0 ? ("/" + std::to_string(event.total)).c_str() : "",
                   event.message.empty() ? "" : "  ", event.message.c_str());
      state->line_open = true;
      if (finished) {
        std::fputc('\n', state->out);
        state->line_open = false;
      }
    } else {
      const bool step = percent >= 0 && percent / 5 > state->last_percent / 5;
      const bool slow = now - state->last_print > std::chrono::seconds(10);
      if (!(new_stage || finished || step || slow)) return;
      std::fprintf(state->out, "%s: %lld%s%s%s%s\n", event.stage.c_str(),
                   static_cast<long long>(event.done),
                   event.total > 0 ? ("/" + std::to_string(event.total)).c_str() : "",
                   percent >= 0 ? (" (" + std::to_string(percent) + "%)").c_str() : "",
                   event.message.empty() ? "" : " ", event.message.c_str());
      state->last_percent = percent;
    }
    state->last_print = now;
    std::fflush(state->out);
  };
}

}  // namespace lookboth
