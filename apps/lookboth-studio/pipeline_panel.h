// The pipeline, left of the views below the settings: one button per step
// (detect, odometry, the configured stages), each step's state, "run
// next" and "run all", and the running job's progress with its Cancel.
// It shows; the window decides (the steps' order is studio::PipelineSteps').
#pragma once

#include <wx/panel.h>

#include <functional>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/studio/pipeline_steps.h"

class wxButton;
class wxGauge;
class wxStaticText;

namespace lookboth::studio_app {

class PipelinePanel : public wxPanel {
 public:
  struct Callbacks {
    std::function<void(int)> run_step;
    std::function<void()> run_all;
    std::function<void()> run_next;
    std::function<void()> cancel;
  };
  PipelinePanel(wxWindow* parent, const studio::PipelineSteps& steps, Callbacks callbacks);

  /// Each step's state; `ready`: a dataset is open, the settings are valid
  /// and no job runs (then only the first pending step may start).
  void showSteps(const studio::PipelineSteps& steps, int running_step, bool ready,
                 bool has_dataset);
  void jobStarted(const std::string& name);
  /// Shows a job's progress; a line for the log when the stage or the
  /// tenth of the work changed, else "".
  wxString jobProgress(const ProgressEvent& event);
  void jobEnded(const wxString& summary, bool succeeded);

 private:
  struct StepWidgets {
    wxButton* button = nullptr;
    wxStaticText* status = nullptr;
  };
  Callbacks callbacks_;
  std::vector<StepWidgets> steps_;
  wxButton* run_all_ = nullptr;
  wxButton* run_next_ = nullptr;
  wxStaticText* stage_text_ = nullptr;
  wxGauge* gauge_ = nullptr;
  wxButton* cancel_ = nullptr;
  std::string last_stage_;
  int last_percent_ = -1;
};

}  // namespace lookboth::studio_app
