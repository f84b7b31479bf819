#include "main_frame.h"

#include <yaml-cpp/yaml.h>

#include <wx/aboutdlg.h>
#include <wx/button.h>
#include <wx/choicdlg.h>
#include <wx/choice.h>
#include <wx/config.h>
#include <wx/dcscreen.h>
#include <wx/dirdlg.h>
#include <wx/filedlg.h>
#include <wx/gauge.h>
#include <wx/listctrl.h>
#include <wx/menu.h>
#include <wx/msgdlg.h>
#include <wx/notebook.h>
#include <wx/panel.h>
#include <wx/radiobox.h>
#include <wx/scrolwin.h>
#include <wx/sizer.h>
#include <wx/slider.h>
#include <wx/spinctrl.h>
#include <wx/splitter.h>
#include <wx/statbox.h>
#include <wx/stattext.h>
#include <wx/statusbr.h>
#include <wx/textctrl.h>
#include <wx/timer.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "image_view.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/core/version.h"
#include "lookboth/dataset/rosbag_import.h"
#include "lookboth/pipeline/full_pipeline.h"
#include "lookboth/report/draw.h"
#include "lookboth/report/report.h"
#include "lookboth/report/snapshot.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/simulate.h"
#include "lookboth/studio/dataset_edit.h"
#include "scene_view.h"

namespace lookboth::studio_app {
namespace {

namespace fs = std::filesystem;

/// The log pane wraps lines to its width itself: one sentence per line.
constexpr std::size_t kNoWidth = 100000;

enum MenuId {
  kIdSimulateFirst = wxID_HIGHEST + 100,  // one item per built-in scenario
  kIdSimulateLast = kIdSimulateFirst + 50,
  kIdRunAll,
  kIdCancel,
  kIdTopView,
  kIdSideView,
  kIdFitView,
  kIdScreenshot,
  kIdNextFrame,
  kIdPrevFrame,
  kIdOpenFolder,
  kIdImportBag,
  kIdRunNext,
  kIdExportReport,
  kIdExportRegistration,
  kIdViewShotFirst,  // one per view: scene, fisheye, camera, table
  kIdViewShotLast = kIdViewShotFirst + 3,
  kIdCycleOverlay,
  kIdLoadCalibration,
  kIdStepFirst,  // one per pipeline step
  kIdStepLast = kIdStepFirst + 30,
};

// What a technician reads for each step (the stage's name when not listed).
std::string stepTitle(const std::string& name) {
  static const std::map<std::string, std::string> titles = {
      {"detect", "Detect markers and blobs"},
      {"odometry", "Visual odometry"},
      {"associate", "Associate detections"},
      {"motion_calibration", "Calibrate (marker on robot)"},
      {"fixed_mount", "Marker mount (fixed)"},
      {"look_down", "Look down (camera poses)"},
      {"look_up", "Look up (refine)"},
      {"joint", "Joint refinement"}};
  const auto it = titles.find(name);
  return it == titles.end() ? name : it->second;
}

const char* kViewNames[] = {"scene", "fisheye", "camera", "table"};

// One line saying what a registration stage gave, from what it wrote.
std::string stageSummary(const std::string& name, const RegistrationProblem& problem,
                         const Registration& r) {
  const std::string cameras = std::to_string(r.registeredCount()) + " of " +
                              std::to_string(r.cameras.size()) + " cameras registered";
  if (name == "associate")
    return std::to_string(problem.associations.size()) + " of " +
           std::to_string(problem.input.markers.size()) +
           " marker detections associated with the trajectory";
  if (name == "motion_calibration" || name == "fixed_mount") {
    std::string line = "scale " + formatFixed(problem.scale, 4);
    if (problem.fisheye_from_marker) {
      const Eigen::Vector3d t = problem.fisheye_from_marker->translation;
      line += ", marker at [" + formatFixed(t.x(), 3) + ", " + formatFixed(t.y(), 3) + ", " +
              formatFixed(t.z(), 3) + "] m from the fisheye";
    }
    return line;
  }
  if (name == "look_up" && r.reprojection)
    return cameras + ", fisheye reprojection RMS " + formatFixed(r.reprojection->rms_px_before, 2) +
           " -> " + formatFixed(r.reprojection->rms_px_after, 2) + " px";
  return cameras;
}

wxImage toWxImage(const cv::Mat& image) {
  cv::Mat rgb;
  if (image.channels() == 1) {
    cv::cvtColor(image, rgb, cv::COLOR_GRAY2RGB);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, rgb, cv::COLOR_BGRA2RGB);
  } else {
    cv::cvtColor(image, rgb, cv::COLOR_BGR2RGB);
  }
  wxImage out(rgb.cols, rgb.rows);
  for (int r = 0; r < rgb.rows; ++r)
    std::copy_n(rgb.ptr<unsigned char>(r), 3 * rgb.cols, out.GetData() + 3 * r * rgb.cols);
  return out;
}

cv::Point toCv(const Eigen::Vector2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x())), static_cast<int>(std::lround(p.y())));
}

// Overlay colours, shared by the legend text (BGR for OpenCV).
const cv::Scalar kBlobColour(60, 220, 60);        // detected blobs: green
const cv::Scalar kProjectedColour(255, 120, 30);  // cameras projected: blue
const cv::Scalar kSelectedColour(0, 200, 255);    // selected camera: amber

std::string formatMetres(double v) { return formatFixed(v, 3); }

}  // namespace

MainFrame::MainFrame(const StartupActions& actions)
    : wxFrame(nullptr, wxID_ANY, "lookboth studio", wxDefaultPosition, wxSize(1500, 950)),
      actions_(actions),
      history_(9) {
  // The steps: detect and odometry, then the configured registration stages.
  std::string config_error;
  try {
    steps_ = studio::PipelineSteps(loadRegistrationConfig(std::nullopt).pipeline);
  } catch (const Error& e) {
    config_error = e.what();
  }
  for (size_t i = 0; i < steps_.size(); ++i) {
    StepWidgets widgets;
    widgets.title = stepTitle(steps_[i].name);
    widgets.menu_id = kIdStepFirst + static_cast<int>(i);
    step_widgets_.push_back(widgets);
  }
  buildMenus();
  CreateStatusBar(2);
  SetStatusText("No dataset open. File > Open (Ctrl+O) or File > Simulate.", 0);

  auto* outer = new wxSplitterWindow(this, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                                     wxSP_LIVE_UPDATE | wxSP_3DSASH);
  auto* setup = buildSetupPanel(outer);
  auto* right = new wxSplitterWindow(outer, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                                     wxSP_LIVE_UPDATE | wxSP_3DSASH);
  auto* views = buildViews(right);
  auto* bottom = buildBottom(right);
  right->SplitHorizontally(views, bottom, -260);
  right->SetSashGravity(1.0);
  right->SetMinimumPaneSize(120);
  outer->SplitVertically(setup, right, 300);
  outer->SetMinimumPaneSize(220);

  wxConfigBase* config = wxConfigBase::Get();
  config->SetPath("/RecentFiles");
  history_.Load(*config);
  config->SetPath("/");

  Bind(wxEVT_CLOSE_WINDOW, [this](wxCloseEvent& event) {
    if (runner_.running()) {
      log("Stopping the running job before closing...");
      runner_.requestStop();
    }
    runner_.wait();
    wxConfigBase* cfg = wxConfigBase::Get();
    cfg->SetPath("/RecentFiles");
    history_.Save(*cfg);
    cfg->SetPath("/");
    cfg->Flush();
    if (actions_.on_close) actions_.on_close(exit_status_);
    event.Skip();
  });
  validateSettings();
  if (!config_error.empty())
    log("error: the registration configuration cannot be read: " +
        wxString::FromUTF8(config_error) + "\nReinstall lookboth or fix the file named above.");
  // Sash positions need the window's real size: set them once it is shown.
  CallAfter([this, outer, right] {
    outer->SetSashPosition(300);
    right->SetSashPosition(std::max(300, right->GetClientSize().y - 250));
    views_split_->SetSashPosition(views_split_->GetClientSize().x * 42 / 100);
    bottom_split_->SetSashPosition(bottom_split_->GetClientSize().x * 64 / 100);
    continueStartup();
  });
}

MainFrame::~MainFrame() {
  runner_.requestStop();
  runner_.wait();
}

void MainFrame::buildMenus() {
  auto* file = new wxMenu;
  file->Append(wxID_OPEN, "&Open dataset...\tCtrl+O",
               "Open a lookboth dataset (.rawlog) or folder");
  file->Append(kIdOpenFolder, "Open &folder dataset...\tCtrl+Shift+O",
               "Open a dataset in the plain folder layout (doc/formats.md)");
  file->Append(kIdImportBag, "&Import ROS bag...\tCtrl+I",
               "Convert a ROS 1 bag to a dataset with a topic mapping file, then open it");
  auto* simulate = new wxMenu;
  const auto scenarios = sim::builtinScenarioNames();
  for (size_t i = 0; i < scenarios.size() && i < 50; ++i)
    simulate->Append(kIdSimulateFirst + static_cast<int>(i), scenarios[i],
                     "Simulate the built-in scenario '" + scenarios[i] + "' and open it");
  file->AppendSubMenu(simulate, "&Simulate scenario");
  auto* recent = new wxMenu;
  history_.UseMenu(recent);
  file->AppendSubMenu(recent, "&Recent datasets");
  file->AppendSeparator();
  file->Append(kIdLoadCalibration, "Load camera &calibration...\tCtrl+L",
               "Give a camera of the dataset the model in a calibration file (lookboth, "
               "OpenCV, Kalibr, ROS...)");
  file->AppendSeparator();
  file->Append(kIdExportReport, "Export &report...\tCtrl+E",
               "Write the HTML report of the finished registration (one file to hand over)");
  file->Append(kIdExportRegistration, "Export re&gistration...\tCtrl+Shift+E",
               "Write the registration files (cameras.csv, registration.yaml...) into a folder");
  file->AppendSeparator();
  file->Append(kIdScreenshot, "Save &screenshot of the window...\tCtrl+Shift+S",
               "Save a PNG of the window");
  auto* view_shots = new wxMenu;
  const char* view_titles[] = {"&3-D scene...\tCtrl+Alt+1", "&Fisheye verification...\tCtrl+Alt+2",
                               "&Environment camera...\tCtrl+Alt+3",
                               "Camera &table...\tCtrl+Alt+4"};
  for (int v = 0; v < 4; ++v) view_shots->Append(kIdViewShotFirst + v, view_titles[v]);
  file->AppendSubMenu(view_shots, "Save screenshot of a &view");
  file->AppendSeparator();
  file->Append(wxID_EXIT, "&Quit\tCtrl+Q");

  auto* pipeline = new wxMenu;
  pipeline_menu_ = pipeline;
  pipeline->Append(kIdRunAll, "Run &all stages\tF5", "Run every step not run yet");
  pipeline->Append(kIdRunNext, "Run &next stage\tF6", "Run the first step not run yet");
  pipeline->AppendSeparator();
  for (size_t i = 0; i < steps_.size(); ++i) {
    wxString item = wxString::Format("&%zu %s", i + 1, wxString::FromUTF8(step_widgets_[i].title));
    if (i < 9) item += wxString::Format("\tAlt+%zu", i + 1);
    pipeline->Append(step_widgets_[i].menu_id, item,
                     wxString::FromUTF8("Run the step '" + steps_[i].name +
                                        "' (once the steps before it have run)"));
  }
  pipeline->AppendSeparator();
  pipeline->Append(kIdCancel, "&Cancel\tEsc");

  auto* view = new wxMenu;
  view->Append(kIdTopView, "&Top view\tCtrl+1");
  view->Append(kIdSideView, "&Side view\tCtrl+2");
  view->Append(kIdFitView, "&Fit all\tCtrl+0");
  view->AppendSeparator();
  view->Append(kIdNextFrame, "&Next frame\tCtrl+Right");
  view->Append(kIdPrevFrame, "&Previous frame\tCtrl+Left");
  view->Append(kIdCycleOverlay, "Fisheye &overlay: before / after / both\tCtrl+B",
               "Show the cameras projected before, after the looking-up refinement, or both");

  auto* help = new wxMenu;
  help->Append(wxID_ABOUT, "&About lookboth studio");

  auto* bar = new wxMenuBar;
  bar->Append(file, "&File");
  bar->Append(pipeline, "&Pipeline");
  bar->Append(view, "&View");
  bar->Append(help, "&Help");
  SetMenuBar(bar);

  Bind(
      wxEVT_MENU,
      [this](wxCommandEvent&) {
        wxFileDialog dialog(this, "Open a lookboth dataset", "", "",
                            "lookboth datasets (*.rawlog;*.yaml)|*.rawlog;*.yaml|All files|*",
                            wxFD_OPEN | wxFD_FILE_MUST_EXIST);
        if (dialog.ShowModal() == wxID_OK) openDataset(dialog.GetPath().ToStdString());
      },
      wxID_OPEN);
  Bind(
      wxEVT_MENU,
      [this, scenarios](wxCommandEvent& e) {
        const size_t i = static_cast<size_t>(e.GetId() - kIdSimulateFirst);
        if (i < scenarios.size()) simulateScenario(scenarios[i], false, "", 0);
      },
      kIdSimulateFirst, kIdSimulateLast);
  Bind(
      wxEVT_MENU,
      [this](wxCommandEvent& e) {
        const wxString path = history_.GetHistoryFile(static_cast<size_t>(e.GetId() - wxID_FILE1));
        if (!path.empty()) openDataset(path.ToStdString());
      },
      wxID_FILE1, wxID_FILE9);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { chooseAndSaveScreenshot(); }, kIdScreenshot);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { Close(); }, wxID_EXIT);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { runAll(); }, kIdRunAll);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { runNext(); }, kIdRunNext);
  Bind(
      wxEVT_MENU,
      [this](wxCommandEvent& e) {
        const int step = e.GetId() - kIdStepFirst;
        if (step >= 0 && step < static_cast<int>(steps_.size())) runStep(step, {});
      },
      kIdStepFirst, kIdStepLast);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { chooseAndExportReport(); }, kIdExportReport);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { chooseAndExportRegistration(); },
      kIdExportRegistration);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent& e) { saveViewScreenshot(e.GetId() - kIdViewShotFirst); },
      kIdViewShotFirst, kIdViewShotLast);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { cycleOverlay(); }, kIdCycleOverlay);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { loadCalibration(); }, kIdLoadCalibration);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { cancelJob(); }, kIdCancel);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { scene_->topView(); }, kIdTopView);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { scene_->sideView(); }, kIdSideView);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { scene_->fitView(); }, kIdFitView);
  Bind(
      wxEVT_MENU,
      [this](wxCommandEvent&) {
        if (frame_slider_->GetValue() < frame_slider_->GetMax())
          showFisheyeFrame(frame_slider_->GetValue() + 1);
      },
      kIdNextFrame);
  Bind(
      wxEVT_MENU,
      [this](wxCommandEvent&) {
        if (frame_slider_->GetValue() > 0) showFisheyeFrame(frame_slider_->GetValue() - 1);
      },
      kIdPrevFrame);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent&) { showAbout(); }, wxID_ABOUT);
}

wxWindow* MainFrame::buildSetupPanel(wxWindow* parent) {
  // Scrolls when the window is too short for every box.
  auto* panel = new wxScrolledWindow(parent, wxID_ANY, wxDefaultPosition, wxDefaultSize, wxVSCROLL);
  panel->SetScrollRate(0, 12);
  setup_panel_ = panel;
  auto* sizer = new wxBoxSizer(wxVERTICAL);

  auto* data_box = new wxStaticBoxSizer(wxVERTICAL, panel, "Dataset");
  dataset_text_ = new wxStaticText(data_box->GetStaticBox(), wxID_ANY, "(none)");
  data_box->Add(dataset_text_, 0, wxALL | wxEXPAND, 4);
  sizer->Add(data_box, 0, wxALL | wxEXPAND, 6);

  auto* marker_box = new wxStaticBoxSizer(wxVERTICAL, panel, "Marker");
  auto* grid = new wxFlexGridSizer(2, 4, 6);
  grid->AddGrowableCol(1);
  wxWindow* mb = marker_box->GetStaticBox();
  grid->Add(new wxStaticText(mb, wxID_ANY, "Dictionary"), 0, wxALIGN_CENTER_VERTICAL);
  dictionary_ = new wxChoice(mb, wxID_ANY);
  for (const auto& [name, count] : knownMarkerDictionaries()) dictionary_->Append(name);
  dictionary_->SetStringSelection("DICT_4X4_50");
  grid->Add(dictionary_, 1, wxEXPAND);
  grid->Add(new wxStaticText(mb, wxID_ANY, "Id"), 0, wxALIGN_CENTER_VERTICAL);
  marker_id_ = new wxSpinCtrl(mb, wxID_ANY, "0", wxDefaultPosition, wxDefaultSize, wxSP_ARROW_KEYS,
                              0, 100000, 0);
  grid->Add(marker_id_, 1, wxEXPAND);
  grid->Add(new wxStaticText(mb, wxID_ANY, "Size [m]"), 0, wxALIGN_CENTER_VERTICAL);
  marker_size_ = new wxTextCtrl(mb, wxID_ANY, "0.2");
  auto* size_row = new wxBoxSizer(wxHORIZONTAL);
  size_row->Add(marker_size_, 1, wxALIGN_CENTER_VERTICAL | wxRIGHT, 4);
  marker_apply_ =
      new wxButton(mb, wxID_ANY, "Apply", wxDefaultPosition, wxDefaultSize, wxBU_EXACTFIT);
  size_row->Add(marker_apply_, 0, wxALIGN_CENTER_VERTICAL);
  grid->Add(size_row, 1, wxEXPAND);
  marker_box->Add(grid, 0, wxALL | wxEXPAND, 4);
  marker_msg_ = new wxStaticText(mb, wxID_ANY, "");
  marker_box->Add(marker_msg_, 0, wxLEFT | wxRIGHT | wxEXPAND, 4);
  marker_apply_->SetToolTip(
      "Write this marker into the dataset's manifest (detection then looks for it)");
  marker_apply_->Disable();
  marker_apply_->Bind(wxEVT_BUTTON, [this](wxCommandEvent&) { applyMarker(); });
  sizer->Add(marker_box, 0, wxLEFT | wxRIGHT | wxEXPAND, 6);

  auto* traj_box = new wxStaticBoxSizer(wxVERTICAL, panel, "Trajectory");
  // Short enough for the settings panel; the tooltip says more.
  const wxString modes[] = {"up to scale (visual)", "metric (scale 1)"};
  trajectory_mode_ = new wxRadioBox(traj_box->GetStaticBox(), wxID_ANY, "Source", wxDefaultPosition,
                                    wxDefaultSize, 2, modes, 1);
  trajectory_mode_->SetToolTip(
      "Up to scale: visual odometry or a monocular SLAM trajectory, whose scale the "
      "registration estimates. Metric: wheels + IMU, LiDAR or motion capture, scale 1.");
  traj_box->Add(trajectory_mode_, 0, wxALL | wxEXPAND, 4);
  auto* label_row = new wxBoxSizer(wxHORIZONTAL);
  label_row->Add(new wxStaticText(traj_box->GetStaticBox(), wxID_ANY, "Trajectory"), 0,
                 wxALIGN_CENTER_VERTICAL | wxRIGHT, 6);
  trajectory_label_ = new wxChoice(traj_box->GetStaticBox(), wxID_ANY);
  label_row->Add(trajectory_label_, 1, wxEXPAND);
  traj_box->Add(label_row, 0, wxALL | wxEXPAND, 4);
  trajectory_msg_ = new wxStaticText(traj_box->GetStaticBox(), wxID_ANY, "");
  traj_box->Add(trajectory_msg_, 0, wxLEFT | wxRIGHT | wxEXPAND, 4);
  sizer->Add(traj_box, 0, wxALL | wxEXPAND, 6);

  auto* loss_box = new wxStaticBoxSizer(wxVERTICAL, panel, "Robust losses");
  auto* lgrid = new wxFlexGridSizer(2, 4, 6);
  lgrid->AddGrowableCol(1);
  wxWindow* lb = loss_box->GetStaticBox();
  lgrid->Add(new wxStaticText(lb, wxID_ANY, "Huber, looking down [sigma]"), 0,
             wxALIGN_CENTER_VERTICAL);
  huber_ = new wxTextCtrl(lb, wxID_ANY, "3.0");
  lgrid->Add(huber_, 1, wxEXPAND);
  lgrid->Add(new wxStaticText(lb, wxID_ANY, "Cauchy, looking up [px]"), 0, wxALIGN_CENTER_VERTICAL);
  cauchy_ = new wxTextCtrl(lb, wxID_ANY, "2.0");
  lgrid->Add(cauchy_, 1, wxEXPAND);
  lgrid->Add(new wxStaticText(lb, wxID_ANY, "Blob gate [px]"), 0, wxALIGN_CENTER_VERTICAL);
  gate_ = new wxTextCtrl(lb, wxID_ANY, "25");
  lgrid->Add(gate_, 1, wxEXPAND);
  loss_box->Add(lgrid, 0, wxALL | wxEXPAND, 4);
  loss_msg_ = new wxStaticText(lb, wxID_ANY, "");
  loss_box->Add(loss_msg_, 0, wxLEFT | wxRIGHT | wxEXPAND, 4);
  sizer->Add(loss_box, 0, wxLEFT | wxRIGHT | wxEXPAND, 6);

  for (wxStaticText* m : {marker_msg_, trajectory_msg_, loss_msg_})
    m->SetForegroundColour(wxColour(200, 30, 30));
  validation_ = new wxStaticText(data_box->GetStaticBox(), wxID_ANY, "");
  validation_->SetForegroundColour(wxColour(200, 30, 30));
  data_box->Add(validation_, 0, wxLEFT | wxRIGHT | wxEXPAND, 4);

  auto* run_box = new wxStaticBoxSizer(wxVERTICAL, panel, "Pipeline (one step at a time, or all)");
  wxWindow* rb = run_box->GetStaticBox();
  auto* steps_grid = new wxFlexGridSizer(2, 2, 6);
  steps_grid->AddGrowableCol(1);
  for (size_t i = 0; i < steps_.size(); ++i) {
    StepWidgets& step = step_widgets_[i];
    step.button = new wxButton(rb, wxID_ANY,
                               wxString::Format("%zu  %s", i + 1, wxString::FromUTF8(step.title)),
                               wxDefaultPosition, wxDefaultSize, wxBU_LEFT);
    step.button->SetToolTip(wxString::FromUTF8("Run the step '" + steps_[i].name + "' (Alt+" +
                                               std::to_string(i + 1) + ")"));
    step.status =
        new wxStaticText(rb, wxID_ANY, "", wxDefaultPosition, wxSize(70, -1), wxST_ELLIPSIZE_END);
    steps_grid->Add(step.button, 0, wxEXPAND);
    steps_grid->Add(step.status, 1, wxALIGN_CENTER_VERTICAL | wxEXPAND);
    const int index = static_cast<int>(i);
    step.button->Bind(wxEVT_BUTTON, [this, index](wxCommandEvent&) { runStep(index, {}); });
  }
  run_box->Add(steps_grid, 0, wxALL | wxEXPAND, 4);
  auto* run_row = new wxBoxSizer(wxHORIZONTAL);
  run_next_ = new wxButton(rb, wxID_ANY, "Run next (F6)");
  run_all_ = new wxButton(rb, wxID_ANY, "Run all (F5)");
  run_row->Add(run_next_, 1, wxRIGHT, 4);
  run_row->Add(run_all_, 1);
  run_box->Add(run_row, 0, wxALL | wxEXPAND, 4);
  stage_text_ = new wxStaticText(run_box->GetStaticBox(), wxID_ANY, "Idle", wxDefaultPosition,
                                 wxDefaultSize, wxST_ELLIPSIZE_END);
  run_box->Add(stage_text_, 0, wxALL | wxEXPAND, 4);
  auto* progress_row = new wxBoxSizer(wxHORIZONTAL);
  gauge_ = new wxGauge(run_box->GetStaticBox(), wxID_ANY, 1000);
  progress_row->Add(gauge_, 1, wxALIGN_CENTER_VERTICAL | wxRIGHT, 6);
  cancel_ = new wxButton(run_box->GetStaticBox(), wxID_ANY, "Cancel (Esc)");
  cancel_->Disable();
  progress_row->Add(cancel_, 0);
  run_box->Add(progress_row, 0, wxALL | wxEXPAND, 4);
  sizer->Add(run_box, 0, wxALL | wxEXPAND, 6);
  sizer->AddStretchSpacer();
  panel->SetSizer(sizer);

  run_all_->Bind(wxEVT_BUTTON, [this](wxCommandEvent&) { runAll(); });
  run_next_->Bind(wxEVT_BUTTON, [this](wxCommandEvent&) { runNext(); });
  cancel_->Bind(wxEVT_BUTTON, [this](wxCommandEvent&) { cancelJob(); });
  auto revalidate = [this](wxCommandEvent& e) {
    validateSettings();
    e.Skip();
  };
  for (wxTextCtrl* t : {marker_size_, huber_, cauchy_, gate_}) t->Bind(wxEVT_TEXT, revalidate);
  dictionary_->Bind(wxEVT_CHOICE, revalidate);
  marker_id_->Bind(wxEVT_SPINCTRL, revalidate);
  trajectory_mode_->Bind(wxEVT_RADIOBOX, revalidate);
  trajectory_label_->Bind(wxEVT_CHOICE, revalidate);
  return panel;
}

wxWindow* MainFrame::buildViews(wxWindow* parent) {
  auto* split = new wxSplitterWindow(parent, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                                     wxSP_LIVE_UPDATE | wxSP_3DSASH);
  auto* scene_panel = new wxPanel(split);
  auto* scene_sizer = new wxBoxSizer(wxVERTICAL);
  scene_ = new SceneView(scene_panel);
  scene_sizer->Add(scene_, 1, wxEXPAND);
  auto* scene_hint = new wxStaticText(
      scene_panel, wxID_ANY,
      "Drag: rotate, wheel: zoom, shift+drag: pan, click: select. Ctrl+1 top, Ctrl+2 side, "
      "Ctrl+0 fit");
  scene_sizer->Add(scene_hint, 0, wxALL, 3);
  scene_panel->SetSizer(scene_sizer);
  scene_->setOnSelect([this](const std::string& label) { selectCamera(label); });

  auto* image_panel = new wxPanel(split);
  auto* image_sizer = new wxBoxSizer(wxVERTICAL);
  image_tabs_ = new wxNotebook(image_panel, wxID_ANY);
  fisheye_view_ = new ImageView(image_tabs_, "Fisheye verification\n(open a dataset)");
  camera_view_ = new ImageView(image_tabs_, "Environment camera\n(select a camera)");
  image_tabs_->AddPage(fisheye_view_, "Fisheye verification");
  image_tabs_->AddPage(camera_view_, "Environment camera");
  image_sizer->Add(image_tabs_, 1, wxEXPAND);
  auto* slider_row = new wxBoxSizer(wxHORIZONTAL);
  frame_slider_ = new wxSlider(image_panel, wxID_ANY, 0, 0, 1);
  frame_text_ =
      new wxStaticText(image_panel, wxID_ANY, "frame -", wxDefaultPosition, wxSize(170, -1));
  slider_row->Add(frame_slider_, 1, wxEXPAND);
  slider_row->Add(frame_text_, 0, wxALIGN_CENTER_VERTICAL | wxLEFT, 6);
  const wxString overlays[] = {"before + after", "after refinement", "before refinement"};
  overlay_choice_ =
      new wxChoice(image_panel, wxID_ANY, wxDefaultPosition, wxDefaultSize, 3, overlays);
  overlay_choice_->SetSelection(0);
  overlay_choice_->SetToolTip(
      "Cameras projected into the fisheye: before and/or after the "
      "looking-up refinement (Ctrl+B cycles)");
  overlay_choice_->Bind(wxEVT_CHOICE, [this](wxCommandEvent&) {
    overlay_mode_ = overlay_choice_->GetSelection();
    showFisheyeFrame(frame_slider_->GetValue());
  });
  slider_row->Add(new wxStaticText(image_panel, wxID_ANY, "Overlay"), 0,
                  wxALIGN_CENTER_VERTICAL | wxLEFT, 8);
  slider_row->Add(overlay_choice_, 0, wxALIGN_CENTER_VERTICAL | wxLEFT, 4);
  image_sizer->Add(slider_row, 0, wxALL | wxEXPAND, 3);
  image_panel->SetSizer(image_sizer);
  frame_slider_->Bind(wxEVT_SLIDER,
                      [this](wxCommandEvent&) { showFisheyeFrame(frame_slider_->GetValue()); });

  views_split_ = split;
  split->SplitVertically(scene_panel, image_panel, 0);
  split->SetSashGravity(0.5);
  split->SetMinimumPaneSize(200);
  return split;
}

wxWindow* MainFrame::buildBottom(wxWindow* parent) {
  auto* split = new wxSplitterWindow(parent, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                                     wxSP_LIVE_UPDATE | wxSP_3DSASH);
  table_ = new wxListCtrl(split, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                          wxLC_REPORT | wxLC_SINGLE_SEL | wxLC_HRULES);
  const char* columns[] = {"Camera",          "Detections",        "Status",       "Residual [mm]",
                           "Sigma pos. [mm]", "Reprojection [px]", "Position [m]", "Warnings"};
  const int widths[] = {75, 85, 95, 105, 120, 125, 175, 320};
  for (int i = 0; i < 8; ++i) table_->AppendColumn(columns[i], wxLIST_FORMAT_LEFT, widths[i]);
  table_->Bind(wxEVT_LIST_ITEM_SELECTED, [this](wxListEvent& e) {
    const long row = e.GetIndex();
    if (row >= 0 && static_cast<size_t>(row) < table_labels_.size())
      selectCamera(table_labels_[static_cast<size_t>(row)]);
  });
  table_->Bind(wxEVT_LIST_COL_CLICK, [this](wxListEvent& e) {
    if (e.GetColumn() == sort_column_) {
      sort_ascending_ = !sort_ascending_;
    } else {
      sort_column_ = e.GetColumn();
      sort_ascending_ = true;
    }
    refreshTable();
  });
  log_ = new wxTextCtrl(split, wxID_ANY, "", wxDefaultPosition, wxDefaultSize,
                        wxTE_MULTILINE | wxTE_READONLY | wxTE_RICH2);
  bottom_split_ = split;
  split->SplitVertically(table_, log_, 0);
  split->SetSashGravity(0.6);
  split->SetMinimumPaneSize(200);
  return split;
}

void MainFrame::log(const wxString& line) {
  log_->AppendText(line + "\n");
  // Unattended runs (--exit) also print the log, for scripts and tests.
  if (actions_.exit) std::fprintf(stderr, "%s\n", line.utf8_str().data());
}

void MainFrame::validateSettings() {
  // Each message goes next to its field; the step buttons wait until all are clear.
  std::vector<std::string> marker_problems, trajectory_problems, loss_problems, dataset_problems;
  MarkerSpec marker;
  marker.dictionary = dictionary_->GetStringSelection().ToStdString();
  marker.id = marker_id_->GetValue();
  const auto size = parseDouble(marker_size_->GetValue().ToStdString());
  marker.size_m = size.value_or(-1);
  if (const std::string m = marker.check(); !m.empty()) marker_problems.push_back(m);
  marker_size_->SetBackgroundColour(size && *size > 0 ? wxNullColour : wxColour(255, 220, 220));
  marker_size_->Refresh();
  // The robust losses: read and checked by the stages' own options, as
  // `lookboth register` reads the same settings over default.yaml.
  std::string loss_error;
  try {
    const RegistrationController check(loadRegistrationConfig(std::nullopt, settingsYaml()));
  } catch (const Error& e) {
    loss_error = e.what();
  }
  if (!loss_error.empty()) loss_problems.push_back(loss_error);
  const std::pair<wxTextCtrl*, const char*> losses[] = {
      {huber_, "look_down.huber'"}, {cauchy_, "look_up.cauchy_px'"}, {gate_, "gate_px'"}};
  for (const auto& [ctrl, key] : losses) {
    const bool bad = loss_error.find(key) != std::string::npos;
    ctrl->SetBackgroundColour(bad ? wxColour(255, 220, 220) : wxNullColour);
    ctrl->Refresh();
  }
  const bool metric = trajectory_mode_->GetSelection() == 1;
  const std::string label = trajectory_label_->GetStringSelection().ToStdString();
  if (trajectory_label_->GetCount() == 0)
    trajectory_problems.push_back("The dataset has no trajectory and no fisheye frames.");
  if (index_) {
    const Manifest& m = index_->manifest();
    const TrajectoryInfo* info = m.findTrajectory(label);
    if (metric && info && !info->metric)
      trajectory_problems.push_back("'" + label + "' is known up to scale: choose visual.");
    if (!metric && label == "vo" && index_->fisheyeFrames().empty() && !index_->trajectory("vo"))
      trajectory_problems.push_back(
          "Visual odometry needs fisheye frames; this dataset has none: choose another "
          "trajectory.");
    if (marker_problems.empty() &&
        (marker.dictionary != m.marker.dictionary || marker.id != m.marker.id ||
         std::abs(marker.size_m - m.marker.size_m) > 1e-9))
      marker_problems.push_back("Differs from the dataset's marker (" + m.marker.dictionary +
                                " id " + std::to_string(m.marker.id) + ", " +
                                formatDouble(m.marker.size_m) +
                                " m), which is used until you apply this one.");
    const CameraSensor* fisheye = m.fisheye();
    if (!fisheye || !fisheye->camera)
      dataset_problems.push_back("The fisheye has no calibration: looking up cannot run.");
    std::string uncalibrated;
    for (const auto& summary : index_->cameraSummaries())
      if (!summary.has_calibration)
        uncalibrated += (uncalibrated.empty() ? "" : ", ") + summary.label;
    if (!uncalibrated.empty())
      dataset_problems.push_back("No camera model for " + uncalibrated +
                                 ": their frames cannot be detected (add the calibration to "
                                 "the dataset's manifest, doc/formats.md).");
  }
  auto show = [](wxStaticText* text, const std::vector<std::string>& problems) {
    std::string joined;
    for (const auto& p : problems) joined += (joined.empty() ? "" : "\n") + p;
    text->SetLabel(wxString::FromUTF8(joined));
    text->Wrap(250);
  };
  show(marker_msg_, marker_problems);
  show(trajectory_msg_, trajectory_problems);
  show(loss_msg_, loss_problems);
  show(validation_, dataset_problems);
  // The marker message about the dataset's marker and the cameras' notes are warnings only.
  const bool marker_blocking = !marker.check().empty();
  marker_apply_->Enable(index_ && !marker_blocking && !marker_problems.empty() &&
                        !runner_.running());
  settings_ok_ = !marker_blocking && trajectory_problems.empty() && loss_problems.empty();
  refreshSteps();
  setup_panel_->Layout();
  setup_panel_->FitInside();
}

bool MainFrame::startJob(const std::string& name, studio::JobRunner::Job job, Then then) {
  if (runner_.running()) {
    wxMessageBox("A job is already running. Wait for it or cancel it (Esc).", "lookboth studio",
                 wxOK | wxICON_INFORMATION, this);
    return false;
  }
  log("> " + wxString::FromUTF8(name));
  last_stage_.clear();
  last_percent_ = -1;
  gauge_->SetValue(0);
  stage_text_->SetLabel(wxString::FromUTF8(name));
  cancel_->Enable();
  const bool started = runner_.start(
      name, std::move(job),
      [this](const ProgressEvent& e) { CallAfter([this, e] { onJobProgress(e); }); },
      [this, then](const studio::JobResult& r) {
        CallAfter([this, r, then] { onJobDone(r, then); });
      });
  refreshSteps();
  return started;
}

void MainFrame::onJobProgress(const ProgressEvent& e) {
  const int permille = e.total > 0 ? static_cast<int>(1000 * e.done / e.total) : 0;
  if (e.total > 0) {
    gauge_->SetValue(std::clamp(permille, 0, 1000));
  } else {
    gauge_->Pulse();
  }
  stage_text_->SetLabel(wxString::FromUTF8(e.stage + (e.message.empty() ? "" : ": " + e.message)));
  const int percent = permille / 100 * 10;
  if (e.stage != last_stage_ || percent != last_percent_) {
    log(wxString::Format("  %s %s%s", wxString::FromUTF8(e.stage),
                         e.total > 0 ? wxString::Format("%d%%", permille / 10) : wxString("..."),
                         e.message.empty() ? wxString() : " " + wxString::FromUTF8(e.message)));
    last_stage_ = e.stage;
    last_percent_ = percent;
  }
}

void MainFrame::onJobDone(const studio::JobResult& r, const Then& then) {
  runner_.wait();
  cancel_->Disable();
  gauge_->SetValue(r.status == studio::JobStatus::kSucceeded ? 1000 : 0);
  const wxString summary = wxString::Format("%s %s in %.1f s", wxString::FromUTF8(r.name),
                                            studio::jobStatusName(r.status), r.seconds);
  stage_text_->SetLabel(summary);
  log("  " + summary);
  const int step = running_step_;
  running_step_ = -1;
  if (r.status != studio::JobStatus::kSucceeded) {
    chain_running_ = false;
    // A registration stage that failed or stopped may have left part of its
    // work in the kept problem: the registration stages start over.
    if (steps_.isStage(step) && pipeline_) {
      resetSteps(true);
      log("  the registration stages will start again from the first one");
    }
  }
  validateSettings();
  if (r.status == studio::JobStatus::kFailed) {
    exit_status_ = 1;
    log("  error: " + wxString::FromUTF8(r.message));
    if (!actions_.exit) {
      wxMessageBox(wxString::FromUTF8(r.message) +
                       "\n\nFix the input named above (file, line or camera) and run again.",
                   wxString::FromUTF8(r.name) + " failed", wxOK | wxICON_ERROR, this);
    }
    if (actions_.exit) CallAfter([this] { continueStartup(); });
    return;
  }
  if (r.status == studio::JobStatus::kStopped) {
    if (actions_.exit) exit_status_ = 1;
    return;
  }
  if (then) then();
}

void MainFrame::openDataset(const std::string& path) {
  startJob(
      "open " + fs::path(path).filename().string(),
      [this, path](const ProgressReporter& progress) {
        auto index = std::make_shared<const studio::DatasetIndex>(
            studio::DatasetIndex::build(path, progress));
        CallAfter([this, index] { datasetLoaded(index); });
      },
      [this, path] {
        history_.AddFileToHistory(wxString::FromUTF8(path));
        continueStartup();
      });
}

void MainFrame::simulateScenario(const std::string& scenario, bool detections_only, std::string out,
                                 double duration_s) {
  if (out.empty()) {
    const fs::path dir = fs::temp_directory_path() / ("lookboth-studio-" + scenario);
    std::error_code ec;
    fs::create_directories(dir, ec);
    out = (dir / (scenario + ".rawlog")).string();
  }
  sim::SimulateOptions options;
  options.scenario = scenario;
  options.out = out;
  options.detections_only = detections_only;
  options.overwrite = true;
  options.max_duration_s = duration_s;
  if (const std::string problem = options.check(); !problem.empty()) {
    wxMessageBox(wxString::FromUTF8(problem), "Cannot simulate", wxOK | wxICON_ERROR, this);
    return;
  }
  startJob(
      "simulate " + scenario,
      [options](const ProgressReporter& progress) { sim::simulate(options, progress); },
      [this, out] { openDataset(out); });
}

void MainFrame::importBag() {
  wxFileDialog bag_dialog(this, "ROS 1 bag to import", "", "", "ROS bags (*.bag)|*.bag|All files|*",
                          wxFD_OPEN | wxFD_FILE_MUST_EXIST);
  if (bag_dialog.ShowModal() != wxID_OK) return;
  wxFileDialog mapping_dialog(this, "Topic mapping (YAML, see the user guide)", "", "",
                              "YAML (*.yaml;*.yml)|*.yaml;*.yml|All files|*",
                              wxFD_OPEN | wxFD_FILE_MUST_EXIST);
  if (mapping_dialog.ShowModal() != wxID_OK) return;
  wxFileDialog out_dialog(this, "Dataset to write", "",
                          fs::path(bag_dialog.GetPath().ToStdString()).stem().string() + ".rawlog",
                          "lookboth dataset (*.rawlog)|*.rawlog",
                          wxFD_SAVE | wxFD_OVERWRITE_PROMPT);
  if (out_dialog.ShowModal() != wxID_OK) return;
  const std::string bag = bag_dialog.GetPath().ToStdString();
  const std::string mapping = mapping_dialog.GetPath().ToStdString();
  const std::string out = out_dialog.GetPath().ToStdString();
  startJob(
      "import " + fs::path(bag).filename().string(),
      [this, bag, mapping, out](const ProgressReporter& progress) {
        RosbagImportOptions options = loadRosbagMapping(mapping);
        options.on_warning = [this](const std::string& w) {
          CallAfter([this, w] { log("  warning: " + wxString::FromUTF8(w)); });
        };
        importRosbag(bag, out, DatasetKind::kRawlog, options, DatasetWriteOptions{true}, progress);
      },
      [this, out] { openDataset(out); });
}

// ---- the pipeline, step by step ----

int MainFrame::firstPendingStep() const { return steps_.firstPending(); }

int MainFrame::stepIndex(const std::string& name) const { return steps_.index(name); }

void MainFrame::resetSteps(bool keep_preparation) {
  steps_.reset(keep_preparation);
  pipeline_.reset();
  refreshSteps();
}

void MainFrame::refreshSteps() {
  const bool idle = !runner_.running();
  const bool ready = index_ && settings_ok_ && idle;
  const int next = firstPendingStep();
  for (size_t i = 0; i < steps_.size(); ++i) {
    const studio::PipelineSteps::Step& step = steps_[i];
    const StepWidgets& widgets = step_widgets_[i];
    using State = studio::PipelineSteps::State;
    // A step runs once every step before it has run (or was not needed).
    const bool enabled = ready && static_cast<int>(i) == next;
    if (widgets.button) {
      widgets.button->Enable(enabled);
      wxString status;
      if (step.state == State::kDone) status = wxString::FromUTF8("\u2714 done");
      if (step.state == State::kSkipped) status = "not needed";
      if (step.state == State::kPending && static_cast<int>(i) == running_step_)
        status = "running...";
      widgets.status->SetLabel(status);
      widgets.status->SetToolTip(wxString::FromUTF8(step.note));
      widgets.status->SetForegroundColour(step.state == State::kDone ? wxColour(20, 130, 40)
                                                                     : wxColour(90, 90, 90));
    }
    if (pipeline_menu_) pipeline_menu_->Enable(widgets.menu_id, enabled);
  }
  const bool all_done = next < 0;
  if (run_all_) {
    run_all_->Enable(ready);
    run_all_->SetLabel(all_done && index_ ? "Run again (F5)" : "Run all (F5)");
    run_next_->Enable(ready && !all_done);
  }
  if (pipeline_menu_) {
    pipeline_menu_->Enable(kIdRunAll, ready);
    pipeline_menu_->Enable(kIdRunNext, ready && !all_done);
  }
  if (GetMenuBar()) {
    GetMenuBar()->Enable(kIdExportReport, idle && !registration_dir_.empty());
    GetMenuBar()->Enable(kIdExportRegistration, idle && registration_ != nullptr);
  }
}

std::string MainFrame::settingsYaml() const {
  // The settings of the panel, as a configuration over the defaults (and the
  // startup's --config), handed to the controller in memory.
  // Each value as a quoted scalar: whatever is typed stays one value, which
  // the stages' options then read as a number or refuse.
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "register" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "look_down" << YAML::Value << YAML::BeginMap << YAML::Key << "huber"
      << YAML::Value << YAML::DoubleQuoted << huber_->GetValue().ToStdString() << YAML::EndMap;
  out << YAML::Key << "look_up" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "cauchy_px" << YAML::Value << YAML::DoubleQuoted
      << cauchy_->GetValue().ToStdString();
  out << YAML::Key << "gate_px" << YAML::Value << YAML::DoubleQuoted
      << gate_->GetValue().ToStdString();
  out << YAML::EndMap << YAML::EndMap << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

void MainFrame::selectTrajectory() {
  const Manifest& m = index_->manifest();
  DatasetContents contents;
  contents.trajectories = m.trajectories;
  contents.fisheye_frames = static_cast<std::int64_t>(index_->fisheyeFrames().size());
  // The command line's choice (chooseTrajectory), unless the startup names a mode.
  TrajectoryChoice choice;
  try {
    choice = chooseTrajectory(index_->path(), contents);
    log("  trajectory: " + wxString::FromUTF8(choice.reason));
  } catch (const Error& e) {
    log("  trajectory: " + wxString::FromUTF8(e.what()));
  }
  // The dataset's trajectories (never its ground truth), and the visual
  // odometry's when it is chosen before it exists.
  trajectory_label_->Clear();
  for (const auto& info : m.trajectories)
    if (info.label != "ground_truth") trajectory_label_->Append(info.label);
  if (!choice.label.empty() && !m.findTrajectory(choice.label))
    trajectory_label_->Append(wxString::FromUTF8(choice.label));
  if (actions_.trajectory == "visual") choice.mode = TrajectoryMode::kVisual;
  if (actions_.trajectory == "metric") {
    choice.mode = TrajectoryMode::kMetric;
    const TrajectoryInfo* chosen = m.findTrajectory(choice.label);
    if (!chosen || !chosen->metric) choice.label = "odometry";
  }
  if (!trajectory_label_->SetStringSelection(wxString::FromUTF8(choice.label)) &&
      trajectory_label_->GetCount() > 0)
    trajectory_label_->SetSelection(0);
  trajectory_mode_->SetSelection(choice.mode == TrajectoryMode::kMetric ? 1 : 0);
}

FullPipelineOptions MainFrame::pipelineOptions() const {
  FullPipelineOptions options;
  options.dataset = index_->path();
  const fs::path dataset(index_->path());
  options.out = dataset.parent_path() / (dataset.stem().string() + "_registration");
  options.overwrite = true;
  options.mode =
      trajectory_mode_->GetSelection() == 1 ? TrajectoryMode::kMetric : TrajectoryMode::kVisual;
  options.trajectory_label = trajectory_label_->GetStringSelection().ToStdString();
  return options;
}

void MainFrame::runAll() {
  if (!index_) {
    wxMessageBox("Open or simulate a dataset first (File menu).", "lookboth studio",
                 wxOK | wxICON_INFORMATION, this);
    return;
  }
  // Everything has run: run the registration stages again (with the current settings).
  if (firstPendingStep() < 0) resetSteps(true);
  runThrough(static_cast<int>(steps_.size()) - 1, [this] { continueStartup(); });
}

void MainFrame::runNext() {
  const int step = firstPendingStep();
  if (step >= 0) runStep(step, {});
}

void MainFrame::runThrough(int last, Then done) {
  const int next = firstPendingStep();
  if (next < 0 || next > last) {
    chain_running_ = false;
    if (done) done();
    return;
  }
  chain_running_ = true;
  runStep(next, [this, last, done] { runThrough(last, done); });
}

void MainFrame::runStep(int step, Then then) {
  if (!index_) {
    wxMessageBox("Open or simulate a dataset first (File menu).", "lookboth studio",
                 wxOK | wxICON_INFORMATION, this);
    return;
  }
  if (step < 0 || step >= static_cast<int>(steps_.size())) return;
  if (step != firstPendingStep()) {
    wxMessageBox("Run the steps before it first (Pipeline menu, F6 runs the next one).",
                 "lookboth studio", wxOK | wxICON_INFORMATION, this);
    return;
  }
  validateSettings();
  if (!settings_ok_) {
    const wxString text = "Fix the settings marked in red first.";
    log("error: " + text);
    if (!actions_.exit)
      wxMessageBox(text, "lookboth studio", wxOK | wxICON_WARNING, this);
    else
      exit_status_ = 1;
    chain_running_ = false;
    if (actions_.exit) CallAfter([this] { continueStartup(); });
    return;
  }
  FullPipelineOptions options = pipelineOptions();
  options.config_overrides = settingsYaml();
  // One step per job through the controller the command line runs. A new
  // one for detection and for the first registration stage (with the
  // panel's settings as they are then): it skips what the dataset has.
  if (step == 0 || step == studio::PipelineSteps::kPreparationSteps || !pipeline_)
    pipeline_ = std::make_shared<PipelineHolder>();

  // What the job hands back to the window.
  struct Output {
    StepOutcome outcome;
    std::shared_ptr<const studio::DatasetIndex> index;
    std::shared_ptr<const Registration> registration;
    std::vector<DetectionRay> rays;
    bool written = false;
  };
  auto output = std::make_shared<Output>();
  const std::string name = steps_[static_cast<size_t>(step)].name;
  std::shared_ptr<PipelineHolder> holder = pipeline_;
  const bool stage = steps_.isStage(step);
  studio::JobRunner::Job job = [options, step, stage, name, output,
                                holder](const ProgressReporter& progress) {
    if (!holder->pipeline) holder->pipeline = std::make_unique<RegistrationPipeline>(options);
    RegistrationPipeline& pipeline = *holder->pipeline;
    // The steps before this one, done already, pass as skipped.
    while (pipeline.stepsRun() < static_cast<std::size_t>(step)) pipeline.runNext(progress);
    if (pipeline.finished() || pipeline.steps()[pipeline.stepsRun()] != name)
      throw Error(ErrorContext{"", 0, "register.pipeline", ""},
                  "the step '" + name + "' is not the next one of the configured pipeline");
    const StepOutcome outcome = pipeline.runNext(progress);
    if (!stage) {
      // detect or odometry: they add to the dataset; the views read it again.
      output->outcome = outcome;
      if (outcome.ran)
        output->index = std::make_shared<const studio::DatasetIndex>(
            studio::DatasetIndex::build(options.dataset, progress));
      return;
    }
    if (pipeline.steps()[pipeline.stepsRun()] == "output") {
      pipeline.runNext(progress);  // the registration directory, after the last stage
      output->written = true;
    }
    const RegistrationSession& s = *pipeline.session();
    RegistrationRun run = s.current();
    output->outcome.ran = true;
    output->outcome.summary = name + ": " + stageSummary(name, s.problem(), run.registration) +
                              (output->written ? "; written to " + options.out.string() : "");
    output->rays = std::move(run.rays);
    output->registration = std::make_shared<const Registration>(std::move(run.registration));
  };
  running_step_ = step;
  const bool started =
      startJob(step_widgets_[static_cast<size_t>(step)].title, std::move(job),
               [this, step, output, out = options.out, then] {
                 if (output->index) datasetLoaded(output->index);
                 if (output->registration) {
                   if (output->written) registration_dir_ = out;
                   registrationReady(index_, output->registration, std::move(output->rays), {});
                 }
                 stepFinished(step, output->outcome);
                 if (then) then();
               });
  if (!started) running_step_ = -1;
}

void MainFrame::stepFinished(int step, const StepOutcome& outcome) {
  steps_.finish(step, outcome.ran, outcome.summary);
  log("  " + wxString::FromUTF8(outcome.summary));
  refreshSteps();
}

void MainFrame::registrationReady(std::shared_ptr<const studio::DatasetIndex> index,
                                  std::shared_ptr<const Registration> registration,
                                  std::vector<DetectionRay> rays, std::vector<std::string> steps) {
  for (const auto& step : steps) log("  " + wxString::FromUTF8(step));
  registration_ = std::move(registration);
  registration_view_ = std::make_shared<const report::RegistrationView>(
      report::viewOfRegistration(*registration_, "registration"));
  rays_ = std::move(rays);
  // Stage by stage, the same messages come again: each is logged once.
  auto once = [this](const std::string& line) {
    if (logged_.insert(line).second) log("  " + wxString::FromUTF8(line));
  };
  for (const auto& w : registration_->labelledWarnings()) once("warning: " + w);
  // One sentence per line: the statement is long.
  if (!registration_->observability.message.empty())
    once("observability:\n" +
         wrapSentences(registration_->observability.message, "    ", kNoWidth));
  datasetLoaded(std::move(index));
}

void MainFrame::cancelJob() {
  if (runner_.running()) {
    log("Cancelling...");
    runner_.requestStop();
  }
}

void MainFrame::datasetLoaded(std::shared_ptr<const studio::DatasetIndex> index) {
  const bool new_dataset = !index_ || index_->path() != index->path();
  index_ = std::move(index);
  if (new_dataset) {
    // Another dataset: nothing has run on it yet.
    registration_.reset();
    registration_view_.reset();
    rays_.clear();
    registration_dir_.clear();
    logged_.clear();
    resetSteps(false);
  }
  const Manifest& m = index_->manifest();
  const auto& counts = index_->recordCounts();
  auto count = [&](const char* kind) {
    const auto it = counts.find(kind);
    return it == counts.end() ? std::int64_t{0} : it->second;
  };
  const int cameras = static_cast<int>(index_->cameraSummaries().size());
  dataset_text_->SetLabel(wxString::FromUTF8(
      m.name + "\n" + std::to_string(cameras) + " environment cameras\n" +
      std::to_string(count("image")) + " images, " + std::to_string(count("marker")) +
      " marker detections,\n" + std::to_string(count("blobs")) + " blob frames, " +
      std::to_string(index_->trajectories().size()) + " trajectories"));
  dataset_text_->Wrap(270);
  if (new_dataset) {
    dictionary_->SetStringSelection(m.marker.dictionary);
    marker_id_->SetValue(m.marker.id);
    marker_size_->ChangeValue(formatDouble(m.marker.size_m));
    selectTrajectory();
  }
  SetTitle(wxString::FromUTF8("lookboth studio - " + m.name));
  SetStatusText(wxString::FromUTF8(index_->path().string()), 0);
  SetStatusText(wxString::Format("%zu input issues", index_->issues().size()), 1);
  for (const auto& issue : index_->issues())
    log("  warning: " + wxString::FromUTF8(issue.where + ": " + issue.message));

  const size_t frames =
      !index_->fisheyeFrames().empty() ? index_->fisheyeFrames().size() : index_->blobs().size();
  frame_slider_->SetRange(0, std::max<int>(0, static_cast<int>(frames) - 1));
  validateSettings();
  refreshTable();
  refreshScene();
  // The frame with the most blobs associated with cameras once looking up has
  // run (the most cameras verified), else with the most blobs.
  int best = 0;
  size_t most = 0;
  std::map<TimeNs, size_t> associated;
  if (const auto* view = static_cast<const report::RegistrationView*>(registration_view_.get()))
    for (const auto& row : view->blob_associations) ++associated[row.t];
  for (size_t i = 0; i < index_->blobs().size(); ++i) {
    const auto it = associated.find(index_->blobs()[i].t);
    const size_t n = associated.empty() ? index_->blobs()[i].blobs.size()
                                        : (it == associated.end() ? 0 : it->second);
    if (n > most) {
      most = n;
      best = static_cast<int>(i);
    }
  }
  if (!index_->fisheyeFrames().empty() && !index_->blobs().empty()) {
    const TimeNs t = index_->blobs()[static_cast<size_t>(best)].t;
    const auto& f = index_->fisheyeFrames();
    best = static_cast<int>(
        std::lower_bound(f.begin(), f.end(), t,
                         [](const studio::FrameRef& a, TimeNs q) { return a.t < q; }) -
        f.begin());
  }
  showFisheyeFrame(std::min<int>(best, frame_slider_->GetMax()));
  const auto rows = index_->cameraSummaries();
  if (selected_.empty() && !rows.empty()) {
    auto most_detected =
        std::max_element(rows.begin(), rows.end(),
                         [](const auto& a, const auto& b) { return a.detections < b.detections; });
    selectCamera(most_detected->label);
  }
}

namespace {

// One row of the camera table, as text, plus the numbers it sorts by.
struct TableRow {
  std::string label;
  std::string cells[8];
  double sort_keys[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  bool warn = false;
};

}  // namespace

void MainFrame::refreshTable() {
  table_->DeleteAllItems();
  table_labels_.clear();
  if (!index_) return;
  std::vector<TableRow> rows;
  for (const auto& summary : index_->cameraSummaries()) {
    TableRow row;
    row.label = summary.label;
    row.cells[0] = summary.label;
    row.cells[1] = std::to_string(summary.detections);
    row.sort_keys[1] = static_cast<double>(summary.detections);
    row.cells[2] = summary.detections > 0 ? "detected" : "not seen";
    for (int c = 3; c < 7; ++c) row.cells[c] = "-";
    if (!summary.has_calibration)
      row.cells[7] = "no calibration: cannot detect";
    else if (summary.detections == 0)
      row.cells[7] = "no marker detection";
    const CameraRegistration* reg =
        registration_ ? registration_->findCamera(summary.label) : nullptr;
    if (reg) {
      row.cells[1] =
          std::to_string(reg->detections.used) + " / " + std::to_string(reg->detections.total);
      row.sort_keys[1] = reg->detections.used;
      row.cells[2] = cameraStatusName(reg->status);
      row.sort_keys[2] = static_cast<double>(reg->status);
      if (reg->residuals) {
        row.cells[3] = formatFixed(1000 * reg->residuals->position_rms_m, 1);
        row.sort_keys[3] = reg->residuals->position_rms_m;
      }
      if (reg->covariance) {
        const double sigma =
            std::sqrt(std::max(0.0, reg->covariance->topLeftCorner<3, 3>().trace()));
        row.cells[4] = formatFixed(1000 * sigma, 1);
        row.sort_keys[4] = sigma;
      }
      if (reg->reprojection && reg->reprojection->blobs > 0) {
        row.cells[5] = formatFixed(reg->reprojection->rms_px_before, 2) + " -> " +
                       formatFixed(reg->reprojection->rms_px_after, 2);
        row.sort_keys[5] = reg->reprojection->rms_px_after;
      }
      if (reg->status != CameraStatus::kUnregistered) {
        const auto& t = reg->world_from_camera.translation;
        row.cells[6] =
            formatMetres(t.x()) + ", " + formatMetres(t.y()) + ", " + formatMetres(t.z());
      }
      std::string notes = reg->reason;
      for (const auto& w : reg->warnings) notes += (notes.empty() ? "" : "; ") + w;
      row.cells[7] = notes;
      row.warn = reg->status != CameraStatus::kRegistered || !reg->warnings.empty();
    } else {
      const auto& truth = index_->manifest().ground_truth.world_from_camera;
      if (const auto it = truth.find(summary.label); it != truth.end()) {
        const auto& t = it->second.translation;
        row.cells[6] = formatMetres(t.x()) + ", " + formatMetres(t.y()) + ", " +
                       formatMetres(t.z()) + " (truth)";
      }
      row.warn = !row.cells[7].empty();
    }
    rows.push_back(std::move(row));
  }
  const int column = std::clamp(sort_column_, 0, 7);
  std::stable_sort(rows.begin(), rows.end(), [&](const TableRow& a, const TableRow& b) {
    const bool numeric = column >= 1 && column <= 5;
    const bool less =
        numeric ? a.sort_keys[column] < b.sort_keys[column] : a.cells[column] < b.cells[column];
    const bool greater =
        numeric ? a.sort_keys[column] > b.sort_keys[column] : a.cells[column] > b.cells[column];
    return sort_ascending_ ? less : greater;
  });
  for (const auto& r : rows) {
    const long i = table_->InsertItem(table_->GetItemCount(), wxString::FromUTF8(r.cells[0]));
    for (int c = 1; c < 8; ++c) table_->SetItem(i, c, wxString::FromUTF8(r.cells[c]));
    if (r.warn) table_->SetItemTextColour(i, wxColour(190, 90, 0));
    table_labels_.push_back(r.label);
    if (r.label == selected_) table_->SetItemState(i, wxLIST_STATE_SELECTED, wxLIST_STATE_SELECTED);
  }
}

void MainFrame::refreshScene() {
  if (!index_) return;
  SceneContent content;
  const Manifest& m = index_->manifest();
  auto add_trajectory = [&](const std::vector<StampedPose>& samples) {
    for (const auto& s : samples)
      if (content.trajectory.empty() ||
          (content.trajectory.back() - s.world_from_body.translation).norm() > 0.05)
        content.trajectory.push_back(s.world_from_body.translation);
  };
  if (registration_) {
    add_trajectory(registration_->trajectory);
    for (const auto& c : registration_->cameras) {
      const int status = c.status == CameraStatus::kRegistered ? 0
                         : c.status == CameraStatus::kSuspect  ? 1
                                                               : 2;
      if (c.status != CameraStatus::kUnregistered)
        content.cameras.push_back(SceneCamera{c.label, c.world_from_camera, status});
    }
    // At most ~16 rays per camera: enough to see where it saw the marker from.
    std::map<std::string, int> rays_per_camera;
    for (const auto& ray : rays_) {
      // Rays are drawn from the camera nearest to their start.
      std::string nearest;
      double best = 0.05;
      for (const auto& c : content.cameras) {
        const double d = (c.world_from_camera.translation - ray.from).norm();
        if (d < best) {
          best = d;
          nearest = c.label;
        }
      }
      if (nearest.empty()) continue;
      const int n = rays_per_camera[nearest]++;
      if (n % std::max<int>(1, static_cast<int>(rays_.size() / content.cameras.size() / 16)) == 0)
        content.rays.emplace_back(nearest, ray.to);
    }
    content.caption = "registration";
  } else {
    const Trajectory* trajectory = index_->trajectory("ground_truth");
    if (trajectory) add_trajectory(trajectory->samples());
    for (const auto& [label, pose] : m.ground_truth.world_from_camera)
      content.cameras.push_back(SceneCamera{label, pose, index_->markers(label).empty() ? 2 : 0});
    // Detection rays: where the marker was when each camera saw it (a sample of them).
    for (const auto& [label, pose] : m.ground_truth.world_from_camera) {
      const auto& markers = index_->markers(label);
      const size_t step = std::max<size_t>(1, markers.size() / 12);
      for (size_t i = 0; i < markers.size(); i += step)
        content.rays.emplace_back(label, (pose * markers[i].camera_from_marker).translation);
    }
    content.caption = "ground truth";
  }
  scene_->setContent(content);
  scene_->setSelected(selected_);
}

void MainFrame::showFisheyeFrame(int i) {
  if (!index_) return;
  const auto& frames = index_->fisheyeFrames();
  const bool has_images = !frames.empty();
  const size_t count = has_images ? frames.size() : index_->blobs().size();
  if (count == 0) {
    fisheye_view_->setPlaceholder("This dataset has no fisheye frames or blobs.");
    return;
  }
  i = std::clamp(i, 0, static_cast<int>(count) - 1);
  frame_slider_->SetValue(i);
  const TimeNs t =
      has_images ? frames[static_cast<size_t>(i)].t : index_->blobs()[static_cast<size_t>(i)].t;
  const CameraSensor* fisheye = index_->manifest().fisheye();
  cv::Mat canvas;
  try {
    if (has_images) {
      canvas = studio::decodeFrame(frames[static_cast<size_t>(i)].image);
    } else if (fisheye && fisheye->camera) {
      canvas = cv::Mat(fisheye->camera->height(), fisheye->camera->width(), CV_8UC3,
                       cv::Scalar(40, 40, 40));
    }
  } catch (const Error& e) {
    fisheye_view_->setPlaceholder(wxString::FromUTF8(e.what()));
    fisheye_view_->setImage(wxImage());
    return;
  }
  if (canvas.empty()) return;
  if (canvas.channels() == 1) cv::cvtColor(canvas, canvas, cv::COLOR_GRAY2BGR);
  const int thickness = std::max(1, canvas.cols / 640);
  int blob_count = 0;
  if (const BlobObservation* blobs = index_->blobsAt(t)) {
    for (const Blob& b : blobs->blobs) {
      cv::circle(canvas, cv::Point(static_cast<int>(b.u), static_cast<int>(b.v)),
                 std::max(10 * thickness, static_cast<int>(b.diameter_px / 2 + 4)), kBlobColour,
                 thickness + 1);
      ++blob_count;
    }
  }
  const auto* view = static_cast<const report::RegistrationView*>(registration_view_.get());
  if (view && fisheye && fisheye->camera) {
    std::vector<Eigen::Vector2d> blob_pixels;
    if (const BlobObservation* blobs = index_->blobsAt(t))
      for (const Blob& b : blobs->blobs) blob_pixels.emplace_back(b.u, b.v);
    report::FisheyeCheck check = report::makeFisheyeCheck(*view, *fisheye->camera, t, blob_pixels);
    check.frame_index = i;
    // The overlay toggle: cameras projected before, after the refinement, or both.
    for (auto& c : check.cameras) {
      if (overlay_mode_ == 1) c.before.reset();
      if (overlay_mode_ == 2) c.after.reset();
    }
    const char* highlighted = overlay_mode_ == 2 ? "before" : "after";
    const TimeNs t0 = has_images ? frames.front().t : index_->blobs().front().t;
    check.seconds = static_cast<double>(t - t0) * 1e-9;
    std::vector<report::OverlayMark> marks;
    const cv::Mat base = has_images ? canvas : cv::Mat();
    cv::Mat drawn = report::drawFisheyeCheck(check, base, canvas.size(), &marks);
    for (const auto& mark : marks) {
      if (mark.label == selected_ && mark.kind == highlighted)
        cv::circle(drawn, cv::Point(static_cast<int>(mark.at.x), static_cast<int>(mark.at.y)),
                   14 * thickness, kSelectedColour, thickness + 1);
    }
    frame_text_->SetLabel(
        wxString::Format("frame %d (0-%zu)   %.2f s", i, count - 1, check.seconds));
    fisheye_view_->setImage(
        toWxImage(drawn),
        wxString::Format("%d cameras in view, %d with their blob; %s; amber ring: selected",
                         static_cast<int>(check.cameras.size()), check.associated(),
                         overlay_mode_ == 0   ? "red: before, blue: after refinement"
                         : overlay_mode_ == 1 ? "blue: after refinement"
                                              : "red: before refinement"));
    showCameraView();
    return;
  }
  // Cameras projected into the frame (ground truth until a registration exists).
  int projected = 0;
  const Trajectory* trajectory = index_->trajectory("ground_truth");
  if (fisheye && fisheye->camera && trajectory) {
    const auto at = trajectory->interpolate(t, 0);
    if (at.ok()) {
      const Rigid3d fisheye_from_world = at.world_from_body.inverse();
      for (const auto& [label, pose] : index_->manifest().ground_truth.world_from_camera) {
        const auto pixel = fisheye->camera->project(fisheye_from_world * pose.translation);
        if (!pixel || !fisheye->camera->isInImage(*pixel)) continue;
        const bool selected = label == selected_;
        const cv::Scalar colour = selected ? kSelectedColour : kProjectedColour;
        const cv::Point p = toCv(*pixel);
        const int s = 5 * thickness;
        cv::line(canvas, p - cv::Point(s, s), p + cv::Point(s, s), colour, thickness + 1);
        cv::line(canvas, p - cv::Point(s, -s), p + cv::Point(s, -s), colour, thickness + 1);
        cv::putText(canvas, label, p + cv::Point(s + 2, -s), cv::FONT_HERSHEY_SIMPLEX,
                    0.45 * thickness, colour, thickness);
        ++projected;
      }
    }
  }
  const TimeNs t0 = has_images ? frames.front().t : index_->blobs().front().t;
  frame_text_->SetLabel(wxString::Format("frame %d (0-%zu)   %.2f s", i, count - 1,
                                         static_cast<double>(t - t0) * 1e-9));
  fisheye_view_->setImage(
      toWxImage(canvas),
      wxString::Format("green o: %d blobs detected   blue x: %d cameras projected (truth)   "
                       "amber: selected",
                       blob_count, projected));
  showCameraView();
}

void MainFrame::showCameraView() {
  if (!index_ || selected_.empty()) return;
  const CameraSensor* sensor = index_->manifest().findCamera(selected_);
  const auto& frames = index_->cameraFrames(selected_);
  const auto& markers = index_->markers(selected_);
  // The camera's frame nearest in time to the fisheye frame shown, else its
  // frame with a detection.
  const auto& fisheye = index_->fisheyeFrames();
  const int fi = frame_slider_->GetValue();
  TimeNs t = 0;
  if (!fisheye.empty()) {
    t = fisheye[static_cast<size_t>(std::clamp<int>(fi, 0, static_cast<int>(fisheye.size()) - 1))]
            .t;
  } else if (!index_->blobs().empty()) {
    t = index_
            ->blobs()[static_cast<size_t>(
                std::clamp<int>(fi, 0, static_cast<int>(index_->blobs().size()) - 1))]
            .t;
  }
  cv::Mat canvas;
  TimeNs frame_t = t;
  if (!frames.empty()) {
    auto it = std::lower_bound(frames.begin(), frames.end(), t,
                               [](const studio::FrameRef& a, TimeNs q) { return a.t < q; });
    if (it == frames.end()) --it;
    if (it != frames.begin() && std::llabs(std::prev(it)->t - t) < std::llabs(it->t - t)) --it;
    try {
      canvas = studio::decodeFrame(it->image);
      frame_t = it->t;
    } catch (const Error& e) {
      camera_view_->setPlaceholder(wxString::FromUTF8(e.what()));
      camera_view_->setImage(wxImage());
      return;
    }
  } else if (sensor && sensor->camera) {
    canvas =
        cv::Mat(sensor->camera->height(), sensor->camera->width(), CV_8UC3, cv::Scalar(40, 40, 40));
  }
  if (canvas.empty()) {
    camera_view_->setPlaceholder(wxString::FromUTF8(selected_ + ": no frames, no calibration"));
    camera_view_->setImage(wxImage());
    return;
  }
  // Times as in the fisheye view: seconds since the first fisheye frame (or blobs).
  TimeNs t0 = frame_t;
  if (!fisheye.empty()) t0 = fisheye.front().t;
  if (fisheye.empty() && !index_->blobs().empty()) t0 = index_->blobs().front().t;
  const std::string when = formatFixed(static_cast<double>(frame_t - t0) * 1e-9, 2) + " s";
  const auto* view = static_cast<const report::RegistrationView*>(registration_view_.get());
  if (view && sensor && sensor->camera) {
    report::EnvCameraView env;
    env.camera = selected_;
    env.t = frame_t;
    env.marker_size_m = index_->manifest().marker.size_m;
    const MarkerObservation* nearest = nullptr;
    for (const auto& m : markers)
      if (std::llabs(m.t - frame_t) < 100'000'000 &&
          (!nearest || std::llabs(m.t - frame_t) < std::llabs(nearest->t - frame_t)))
        nearest = &m;
    if (nearest) env.detected_camera_from_marker = nearest->camera_from_marker;
    const auto camera_pose = view->world_from_camera.find(selected_);
    const auto robot = view->trajectory.interpolate(frame_t, 0);
    if (camera_pose != view->world_from_camera.end() && robot.ok() && view->fisheye_from_marker)
      env.predicted_camera_from_marker =
          camera_pose->second.inverse() * robot.world_from_body * *view->fisheye_from_marker;
    const cv::Mat drawn = report::drawEnvCameraView(
        env, *sensor->camera, frames.empty() ? cv::Mat() : canvas, canvas.size());
    camera_view_->setImage(
        toWxImage(drawn),
        wxString::FromUTF8(selected_ + "  " + when +
                           "   yellow: detected marker, magenta: where the registration puts it"));
    return;
  }
  if (canvas.channels() == 1) cv::cvtColor(canvas, canvas, cv::COLOR_GRAY2BGR);
  // The marker detection nearest in time (within 100 ms), with its axes.
  wxString caption = wxString::FromUTF8(selected_ + "  " + when);
  const MarkerObservation* nearest = nullptr;
  for (const auto& m : markers)
    if (std::llabs(m.t - frame_t) < 100'000'000 &&
        (!nearest || std::llabs(m.t - frame_t) < std::llabs(nearest->t - frame_t)))
      nearest = &m;
  if (nearest && sensor && sensor->camera) {
    const double size = index_->manifest().marker.size_m;
    const Rigid3d& c = nearest->camera_from_marker;
    const auto origin = sensor->camera->project(c.translation);
    const Eigen::Vector3d axes[3] = {Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                     Eigen::Vector3d::UnitZ()};
    const cv::Scalar colours[3] = {cv::Scalar(40, 40, 255), cv::Scalar(40, 220, 40),
                                   cv::Scalar(255, 80, 40)};
    const int thickness = std::max(1, canvas.cols / 480);
    if (origin) {
      for (int k = 0; k < 3; ++k) {
        const auto end = sensor->camera->project(c * (axes[k] * size));
        if (end) cv::line(canvas, toCv(*origin), toCv(*end), colours[k], thickness + 1);
      }
      // The square's outline.
      std::vector<cv::Point> outline;
      for (const auto& corner : {Eigen::Vector3d(-1, 1, 0), Eigen::Vector3d(1, 1, 0),
                                 Eigen::Vector3d(1, -1, 0), Eigen::Vector3d(-1, -1, 0)}) {
        const auto p = sensor->camera->project(c * (corner * size / 2));
        if (p) outline.push_back(toCv(*p));
      }
      if (outline.size() == 4) cv::polylines(canvas, outline, true, kSelectedColour, thickness);
    }
    caption += wxString::Format("   marker at %.2f m   (axes x red, y green, z blue)",
                                c.translation.norm());
  } else {
    caption += "   no marker detection near this time";
  }
  camera_view_->setImage(toWxImage(canvas), caption);
}

void MainFrame::selectCamera(const std::string& label) {
  if (label == selected_) return;
  selected_ = label;
  scene_->setSelected(label);
  for (size_t i = 0; i < table_labels_.size(); ++i) {
    const bool on = table_labels_[i] == label;
    table_->SetItemState(static_cast<long>(i), on ? wxLIST_STATE_SELECTED : 0,
                         wxLIST_STATE_SELECTED);
    if (on) table_->EnsureVisible(static_cast<long>(i));
  }
  SetStatusText(wxString::FromUTF8("selected " + label), 1);
  showFisheyeFrame(frame_slider_->GetValue());
}

void MainFrame::saveScreenshot(const std::string& path) {
  Raise();
  Update();
  const wxRect rect = GetScreenRect();
  wxBitmap bitmap(rect.width, rect.height);
  {
    wxScreenDC screen;
    wxMemoryDC memory(bitmap);
    memory.Blit(0, 0, rect.width, rect.height, &screen, rect.x, rect.y);
  }
  const fs::path target(path);
  const fs::path temporary = target.parent_path() / (target.filename().string() + ".tmp.png");
  if (!bitmap.ConvertToImage().SaveFile(wxString::FromUTF8(temporary.string()),
                                        wxBITMAP_TYPE_PNG)) {
    log("error: cannot write " + wxString::FromUTF8(path));
    exit_status_ = 1;
    return;
  }
  std::error_code ec;
  fs::rename(temporary, target, ec);
  if (ec) {
    log("error: cannot write " + wxString::FromUTF8(path) + ": " + ec.message());
    exit_status_ = 1;
    return;
  }
  log("Screenshot saved: " + wxString::FromUTF8(path));
  // One picture per view beside it (<name>-scene.png, -fisheye.png, -table.png),
  // so that each can be checked or put in a document on its own.
  const std::pair<wxWindow*, const char*> views[] = {
      {scene_, "scene"}, {fisheye_view_, "fisheye"}, {camera_view_, "camera"}, {table_, "table"}};
  for (const auto& [view, name] : views) {
    const fs::path part =
        target.parent_path() / (target.stem().string() + "-" + name + target.extension().string());
    // The image views draw themselves off screen (the hidden tab too).
    if (view == fisheye_view_ || view == camera_view_) {
      const wxImage image =
          static_cast<ImageView*>(view)->render(image_tabs_->GetCurrentPage()->GetClientSize());
      if (image.IsOk()) image.SaveFile(wxString::FromUTF8(part.string()), wxBITMAP_TYPE_PNG);
      continue;
    }
    if (!view->IsShownOnScreen()) continue;
    wxRect r = view->GetScreenRect();
    r.Offset(-rect.x, -rect.y);
    r.Intersect(wxRect(0, 0, rect.width, rect.height));
    if (r.IsEmpty()) continue;
    bitmap.GetSubBitmap(r).ConvertToImage().SaveFile(wxString::FromUTF8(part.string()),
                                                     wxBITMAP_TYPE_PNG);
  }
}

void MainFrame::chooseAndSaveScreenshot() {
  wxFileDialog dialog(this, "Save a screenshot", "", "lookboth-studio.png", "PNG (*.png)|*.png",
                      wxFD_SAVE | wxFD_OVERWRITE_PROMPT);
  if (dialog.ShowModal() == wxID_OK) saveScreenshot(dialog.GetPath().ToStdString());
}

void MainFrame::saveViewScreenshot(int view) {
  wxWindow* windows[] = {scene_, fisheye_view_, camera_view_, table_};
  if (view < 0 || view > 3) return;
  wxWindow* window = windows[view];
  // The image views live in tabs: show the one asked for.
  if (window == fisheye_view_) image_tabs_->SetSelection(0);
  if (window == camera_view_) image_tabs_->SetSelection(1);
  wxFileDialog dialog(this, "Save a screenshot of a view", "",
                      wxString("lookboth-") + kViewNames[view] + ".png", "PNG (*.png)|*.png",
                      wxFD_SAVE | wxFD_OVERWRITE_PROMPT);
  if (dialog.ShowModal() != wxID_OK) return;
  Raise();
  Update();
  wxImage image;
  if (window == fisheye_view_ || window == camera_view_) {
    image = static_cast<ImageView*>(window)->render();
  } else {
    const wxRect r = window->GetScreenRect();
    wxBitmap bitmap(r.width, r.height);
    {
      wxScreenDC screen;
      wxMemoryDC memory(bitmap);
      memory.Blit(0, 0, r.width, r.height, &screen, r.x, r.y);
    }
    image = bitmap.ConvertToImage();
  }
  const fs::path target(dialog.GetPath().ToStdString());
  const fs::path temporary = target.parent_path() / (target.filename().string() + ".tmp.png");
  std::error_code ec;
  if (image.IsOk() && image.SaveFile(wxString::FromUTF8(temporary.string()), wxBITMAP_TYPE_PNG))
    fs::rename(temporary, target, ec);
  else
    ec = std::make_error_code(std::errc::io_error);
  if (ec) {
    wxMessageBox("Cannot write " + wxString::FromUTF8(target.string()) +
                     ": choose a folder you can write to.",
                 "Screenshot not saved", wxOK | wxICON_ERROR, this);
    return;
  }
  log("Screenshot of the " + wxString(kViewNames[view]) +
      " view saved: " + wxString::FromUTF8(target.string()));
}

void MainFrame::cycleOverlay() {
  overlay_mode_ = (overlay_mode_ + 1) % 3;
  overlay_choice_->SetSelection(overlay_mode_);
  image_tabs_->SetSelection(0);
  showFisheyeFrame(frame_slider_->GetValue());
}

// ---- the marker ----

void MainFrame::applyMarker() {
  if (!index_) return;
  MarkerSpec marker;
  marker.dictionary = dictionary_->GetStringSelection().ToStdString();
  marker.id = marker_id_->GetValue();
  marker.size_m = parseDouble(marker_size_->GetValue().ToStdString()).value_or(-1);
  const fs::path dataset = index_->path();
  auto index = std::make_shared<std::shared_ptr<const studio::DatasetIndex>>();
  startJob(
      "apply the marker",
      [dataset, marker, index](const ProgressReporter& progress) {
        studio::setMarker(dataset, marker, progress);
        *index = std::make_shared<const studio::DatasetIndex>(
            studio::DatasetIndex::build(dataset, progress));
      },
      [this, marker, index] {
        registration_.reset();
        registration_view_.reset();
        rays_.clear();
        registration_dir_.clear();
        resetSteps(false);
        log(wxString::FromUTF8("  marker " + marker.dictionary + " id " +
                               std::to_string(marker.id) + ", " + formatDouble(marker.size_m) +
                               " m written into the dataset; detections made for the old "
                               "marker stay until detection runs again (lookboth detect)"));
        datasetLoaded(*index);
      });
}

// ---- camera models ----

void MainFrame::loadCalibration() {
  if (!index_) {
    wxMessageBox("Open a dataset first (File menu).", "lookboth studio", wxOK | wxICON_INFORMATION,
                 this);
    return;
  }
  wxArrayString labels;
  int preselected = 0;
  for (const CameraSensor& c : index_->manifest().cameras) {
    if (c.label == selected_) preselected = static_cast<int>(labels.size());
    labels.Add(wxString::FromUTF8(c.label + (c.camera ? "" : "  (no calibration)")));
  }
  if (labels.empty()) return;
  wxSingleChoiceDialog choose(this, "Camera whose calibration to load:", "Load camera calibration",
                              labels);
  choose.SetSelection(preselected);
  if (choose.ShowModal() != wxID_OK) return;
  const std::string label =
      index_->manifest().cameras[static_cast<size_t>(choose.GetSelection())].label;
  wxFileDialog file_dialog(this, wxString::FromUTF8("Calibration file for " + label), "", "",
                           "Calibrations (*.yaml;*.yml;*.xml;*.json;*.txt)|"
                           "*.yaml;*.yml;*.xml;*.json;*.txt|All files|*",
                           wxFD_OPEN | wxFD_FILE_MUST_EXIST);
  if (file_dialog.ShowModal() != wxID_OK) return;
  loadCalibrationFor(label, file_dialog.GetPath().ToStdString(), {});
}

void MainFrame::loadCalibrationFor(const std::string& label, const std::string& file, Then then) {
  if (!index_) return;
  const fs::path dataset = index_->path();
  auto index = std::make_shared<std::shared_ptr<const studio::DatasetIndex>>();
  startJob(
      "load calibration of " + label,
      [dataset, label, file, index](const ProgressReporter& progress) {
        studio::setCameraCalibration(dataset, label, file, progress);
        *index = std::make_shared<const studio::DatasetIndex>(
            studio::DatasetIndex::build(dataset, progress));
      },
      [this, label, file, index, then] {
        // The input changed: what ran on it runs again.
        registration_.reset();
        registration_view_.reset();
        rays_.clear();
        registration_dir_.clear();
        resetSteps(false);
        log(wxString::FromUTF8("  " + label + ": calibration from " + file +
                               "; detections made with the old model stay until detection "
                               "runs again (lookboth detect)"));
        datasetLoaded(*index);
        if (then) then();
      });
}

// ---- export ----

void MainFrame::exportRegistration(const std::string& dir) {
  if (!registration_) {
    log("error: no registration to export yet: run the stages first");
    if (actions_.exit) exit_status_ = 1;
    return;
  }
  RegistrationRun run;
  run.registration = *registration_;
  run.rays = rays_;
  try {
    writeRegistrationOutput(run, dir, true);
  } catch (const Error& e) {
    log("error: " + wxString::FromUTF8(e.what()));
    if (actions_.exit) {
      exit_status_ = 1;
    } else {
      wxMessageBox(wxString::FromUTF8(e.what()) +
                       "\n\nChoose a folder whose parent exists and "
                       "that you can write to.",
                   "Registration not exported", wxOK | wxICON_ERROR, this);
    }
    return;
  }
  std::string stages;
  for (const auto& stage : registration_->pipeline) stages += (stages.empty() ? "" : ", ") + stage;
  log("Registration written to " + wxString::FromUTF8(dir) +
      " (stages run: " + wxString::FromUTF8(stages) + ")");
}

void MainFrame::chooseAndExportRegistration() {
  if (!registration_) return;
  wxDirDialog dialog(this, "Folder to write the registration into (created or replaced)");
  if (dialog.ShowModal() == wxID_OK) exportRegistration(dialog.GetPath().ToStdString());
}

void MainFrame::exportReport(const std::string& path, Then then) {
  if (registration_dir_.empty() || !index_) {
    const wxString text = "The report needs a finished registration: run every stage first (F5).";
    log("error: " + text);
    if (actions_.exit)
      exit_status_ = 1;
    else
      wxMessageBox(text, "lookboth studio", wxOK | wxICON_INFORMATION, this);
    if (then) then();
    return;
  }
  // A folder gets report.html inside it.
  fs::path file(path);
  if (file.extension() != ".html") file /= "report.html";
  report::ReportOptions options;
  options.out = file;
  // Simulated datasets carry the truth: the report then compares with it.
  if (!index_->manifest().ground_truth.world_from_camera.empty())
    options.ground_truth = index_->path();
  const fs::path dataset = index_->path();
  const fs::path registration = registration_dir_;
  auto summary = std::make_shared<report::ReportSummary>();
  startJob(
      "export report",
      [options, dataset, registration, summary](const ProgressReporter& progress) {
        std::error_code ec;
        if (!options.out.parent_path().empty())
          fs::create_directories(options.out.parent_path(), ec);
        *summary = report::writeReport(dataset, registration, options, progress);
      },
      [this, file, summary, then] {
        log(wxString::FromUTF8(
            "  report written: " + file.string() + " (" + std::to_string(summary->pictures) +
            " pictures, verdict: " + report::verdictName(summary->verdict) + ")"));
        for (const auto& reason : summary->reasons) log("  verdict: " + wxString::FromUTF8(reason));
        if (then) then();
      });
}

void MainFrame::chooseAndExportReport() {
  if (registration_dir_.empty()) return;
  wxFileDialog dialog(this, "Export the HTML report", "", "lookboth-report.html",
                      "HTML (*.html)|*.html", wxFD_SAVE | wxFD_OVERWRITE_PROMPT);
  if (dialog.ShowModal() == wxID_OK) exportReport(dialog.GetPath().ToStdString(), {});
}

void MainFrame::showAbout() {
  wxAboutDialogInfo info;
  info.SetName("lookboth studio");
  info.SetVersion(versionString());
  info.SetDescription(
      "Registers a network of fixed, ceiling-mounted cameras with a robot that carries an "
      "upward fisheye and a backlit marker: look both ways.\n\nBuilt with:\n" +
      wxString::FromUTF8(buildInfo()) + "\n" + wxString(wxVERSION_STRING));
  wxAboutBox(info, this);
}

// The unattended sequence of --open/--simulate, --run-all, --select,
// --frame, --screenshot, --exit: each step runs when the previous one ends.
void MainFrame::continueStartup() {
  switch (startup_step_++) {
    case 0:
      if (!actions_.simulate.empty()) {
        simulateScenario(actions_.simulate, actions_.detections_only, actions_.simulate_out,
                         actions_.duration_s);
        return;
      }
      if (!actions_.open.empty()) {
        openDataset(actions_.open);
        return;
      }
      [[fallthrough]];
    case 1:
      // --calibration LABEL=FILE, one job each, before running anything.
      if (calibrations_done_ < actions_.calibrations.size() && index_) {
        const auto& [label, file] = actions_.calibrations[calibrations_done_++];
        --startup_step_;
        loadCalibrationFor(label, file, [this] { continueStartup(); });
        return;
      }
      if ((actions_.run_all || !actions_.run_until.empty()) && index_) {
        int last = static_cast<int>(steps_.size()) - 1;
        if (!actions_.run_all) last = stepIndex(actions_.run_until);
        if (last < 0) {
          log(wxString::FromUTF8("error: --run-until: no step '" + actions_.run_until +
                                 "' (steps: " + steps_.names() + ")"));
          exit_status_ = 1;
        } else {
          runThrough(last, [this] { continueStartup(); });
          return;
        }
      }
      ++startup_step_;
      [[fallthrough]];
    case 2:
      if (actions_.overlay == "after") overlay_mode_ = 1;
      if (actions_.overlay == "before") overlay_mode_ = 2;
      overlay_choice_->SetSelection(overlay_mode_);
      if (!actions_.select.empty()) selectCamera(actions_.select);
      showFisheyeFrame(actions_.frame >= 0 ? actions_.frame : frame_slider_->GetValue());
      if (!actions_.export_registration.empty()) exportRegistration(actions_.export_registration);
      if (!actions_.export_report.empty()) {
        exportReport(actions_.export_report, [this] { continueStartup(); });
        return;
      }
      ++startup_step_;
      [[fallthrough]];
    case 3: {
      if (actions_.screenshot.empty() && !actions_.exit) return;
      // Let the views (the OpenGL one in particular) draw before capturing.
      auto* timer = new wxTimer();
      timer->Bind(wxEVT_TIMER, [this, timer](wxTimerEvent&) {
        if (!actions_.screenshot.empty()) saveScreenshot(actions_.screenshot);
        timer->Stop();
        if (actions_.exit) Close(true);
        CallAfter([timer] { delete timer; });
      });
      timer->StartOnce(1500);
      return;
    }
    default:
      return;
  }
}

}  // namespace lookboth::studio_app
