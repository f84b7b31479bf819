#include "pipeline_panel.h"

#include <wx/button.h>
#include <wx/gauge.h>
#include <wx/sizer.h>
#include <wx/statbox.h>
#include <wx/stattext.h>

#include <algorithm>
#include <utility>

#include "lookboth/studio/step_runner.h"

namespace lookboth::studio_app {

PipelinePanel::PipelinePanel(wxWindow* parent, const studio::PipelineSteps& steps,
                             Callbacks callbacks)
    : wxPanel(parent), callbacks_(std::move(callbacks)) {
  auto* box = new wxStaticBoxSizer(wxVERTICAL, this, "Pipeline (one step at a time, or all)");
  wxWindow* rb = box->GetStaticBox();
  auto* grid = new wxFlexGridSizer(2, 2, 6);
  grid->AddGrowableCol(1);
  for (size_t i = 0; i < steps.size(); ++i) {
    StepWidgets widgets;
    const std::string title = studio::stepTitle(steps[i].name);
    widgets.button =
        new wxButton(rb, wxID_ANY, wxString::Format("%zu  %s", i + 1, wxString::FromUTF8(title)),
                     wxDefaultPosition, wxDefaultSize, wxBU_LEFT);
    widgets.button->SetToolTip(wxString::FromUTF8("Run the step '" + steps[i].name + "' (Alt+" +
                                                  std::to_string(i + 1) + ")"));
    widgets.status =
        new wxStaticText(rb, wxID_ANY, "", wxDefaultPosition, wxSize(70, -1), wxST_ELLIPSIZE_END);
    grid->Add(widgets.button, 0, wxEXPAND);
    grid->Add(widgets.status, 1, wxALIGN_CENTER_VERTICAL | wxEXPAND);
    const int index = static_cast<int>(i);
    widgets.button->Bind(wxEVT_BUTTON, [this, index](wxCommandEvent&) {
      if (callbacks_.run_step) callbacks_.run_step(index);
    });
    steps_.push_back(widgets);
  }
  box->Add(grid, 0, wxALL | wxEXPAND, 4);
  auto* run_row = new wxBoxSizer(wxHORIZONTAL);
  run_next_ = new wxButton(rb, wxID_ANY, "Run next (F6)");
  run_all_ = new wxButton(rb, wxID_ANY, "Run all (F5)");
  run_row->Add(run_next_, 1, wxRIGHT, 4);
  run_row->Add(run_all_, 1);
  box->Add(run_row, 0, wxALL | wxEXPAND, 4);
  stage_text_ =
      new wxStaticText(rb, wxID_ANY, "Idle", wxDefaultPosition, wxDefaultSize, wxST_ELLIPSIZE_END);
  box->Add(stage_text_, 0, wxALL | wxEXPAND, 4);
  auto* progress_row = new wxBoxSizer(wxHORIZONTAL);
  gauge_ = new wxGauge(rb, wxID_ANY, 1000);
  progress_row->Add(gauge_, 1, wxALIGN_CENTER_VERTICAL | wxRIGHT, 6);
  cancel_ = new wxButton(rb, wxID_ANY, "Cancel (Esc)");
  cancel_->Disable();
  progress_row->Add(cancel_, 0);
  box->Add(progress_row, 0, wxALL | wxEXPAND, 4);
  auto* sizer = new wxBoxSizer(wxVERTICAL);
  sizer->Add(box, 0, wxALL | wxEXPAND, 6);
  SetSizer(sizer);

  run_all_->Bind(wxEVT_BUTTON, [this](wxCommandEvent&) { callbacks_.run_all(); });
  run_next_->Bind(wxEVT_BUTTON, [this](wxCommandEvent&) { callbacks_.run_next(); });
  cancel_->Bind(wxEVT_BUTTON, [this](wxCommandEvent&) { callbacks_.cancel(); });
}

void PipelinePanel::showSteps(const studio::PipelineSteps& steps, int running_step, bool ready,
                              bool has_dataset) {
  using State = studio::PipelineSteps::State;
  const int next = steps.firstPending();
  for (size_t i = 0; i < steps.size() && i < steps_.size(); ++i) {
    const studio::PipelineSteps::Step& step = steps[i];
    const StepWidgets& widgets = steps_[i];
    // A step runs once every step before it has run (or was not needed).
    widgets.button->Enable(ready && static_cast<int>(i) == next);
    wxString status;
    if (step.state == State::kDone) status = wxString::FromUTF8("\u2714 done");
    if (step.state == State::kSkipped) status = "not needed";
    if (step.state == State::kPending && static_cast<int>(i) == running_step) status = "running...";
    widgets.status->SetLabel(status);
    widgets.status->SetToolTip(wxString::FromUTF8(step.note));
    widgets.status->SetForegroundColour(step.state == State::kDone ? wxColour(20, 130, 40)
                                                                   : wxColour(90, 90, 90));
  }
  const bool all_done = next < 0;
  run_all_->Enable(ready);
  run_all_->SetLabel(all_done && has_dataset ? "Run again (F5)" : "Run all (F5)");
  run_next_->Enable(ready && !all_done);
}

void PipelinePanel::jobStarted(const std::string& name) {
  last_stage_.clear();
  last_percent_ = -1;
  gauge_->SetValue(0);
  stage_text_->SetLabel(wxString::FromUTF8(name));
  cancel_->Enable();
}

wxString PipelinePanel::jobProgress(const ProgressEvent& e) {
  const int permille = e.total > 0 ? static_cast<int>(1000 * e.done / e.total) : 0;
  if (e.total > 0) {
    gauge_->SetValue(std::clamp(permille, 0, 1000));
  } else {
    gauge_->Pulse();
  }
  stage_text_->SetLabel(wxString::FromUTF8(e.stage + (e.message.empty() ? "" : ": " + e.message)));
  const int percent = permille / 100 * 10;
  if (e.stage == last_stage_ && percent == last_percent_) return {};
  last_stage_ = e.stage;
  last_percent_ = percent;
  return wxString::Format("  %s %s%s", wxString::FromUTF8(e.stage),
                          e.total > 0 ? wxString::Format("%d%%", permille / 10) : wxString("..."),
                          e.message.empty() ? wxString() : " " + wxString::FromUTF8(e.message));
}

void PipelinePanel::jobEnded(const wxString& summary, bool succeeded) {
  cancel_->Disable();
  gauge_->SetValue(succeeded ? 1000 : 0);
  stage_text_->SetLabel(summary);
}

}  // namespace lookboth::studio_app
