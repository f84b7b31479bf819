#include "main_frame.h"

#include <wx/aboutdlg.h>
#include <wx/choicdlg.h>
#include <wx/config.h>
#include <wx/dcmemory.h>
#include <wx/dcscreen.h>
#include <wx/dirdlg.h>
#include <wx/filedlg.h>
#include <wx/menu.h>
#include <wx/msgdlg.h>
#include <wx/notebook.h>
#include <wx/scrolwin.h>
#include <wx/sizer.h>
#include <wx/splitter.h>
#include <wx/statusbr.h>
#include <wx/textctrl.h>
#include <wx/timer.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "camera_table.h"
#include "image_view.h"
#include "lookboth/calib/fixed_markers.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/core/version.h"
#include "lookboth/dataset/rosbag_import.h"
#include "lookboth/export/export.h"
#include "lookboth/registration/site_frame.h"
#include "lookboth/report/report.h"
#include "lookboth/report/snapshot.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/simulate.h"
#include "lookboth/studio/dataset_edit.h"
#include "pipeline_panel.h"
#include "scene_view.h"
#include "setup_panel.h"
#include "views_panel.h"

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
  kIdExportFormatFirst,  // one per export format, then "all"
  kIdExportFormatLast = kIdExportFormatFirst + 8,
  kIdAlignFloor,
  kIdAlignControlPoints,
  kIdAlignControlPointsScaled,
  kIdCheckAgainst,
  kIdUpdateRecord,
  kIdViewShotFirst,  // one per view: scene, fisheye, camera, table
  kIdViewShotLast = kIdViewShotFirst + 3,
  kIdCycleOverlay,
  kIdLoadCalibration,
  kIdStepFirst,  // one per pipeline step
  kIdStepLast = kIdStepFirst + 30,
};

const char* kViewNames[] = {"scene", "fisheye", "camera", "table"};

/// The steps: detect and odometry, then the configured registration stages.
studio::PipelineSteps configuredSteps(std::string& error) {
  try {
    return studio::PipelineSteps(loadRegistrationConfig(std::nullopt).pipeline);
  } catch (const Error& e) {
    error = e.what();
    return studio::PipelineSteps();
  }
}

/// Writes `image` to `target` through a temporary file; whether it was written.
bool savePng(const wxImage& image, const fs::path& target) {
  const fs::path temporary = target.parent_path() / (target.filename().string() + ".tmp.png");
  if (!image.IsOk() || !image.SaveFile(wxString::FromUTF8(temporary.string()), wxBITMAP_TYPE_PNG))
    return false;
  std::error_code ec;
  fs::rename(temporary, target, ec);
  return !ec;
}

wxBitmap grabScreen(const wxRect& rect) {
  wxBitmap bitmap(rect.width, rect.height);
  wxScreenDC screen;
  wxMemoryDC memory(bitmap);
  memory.Blit(0, 0, rect.width, rect.height, &screen, rect.x, rect.y);
  return bitmap;
}

}  // namespace

MainFrame::MainFrame(const StartupActions& actions)
    : wxFrame(nullptr, wxID_ANY, "lookboth studio", wxDefaultPosition, wxSize(1500, 950)),
      startup_(actions, *this),
      unattended_(actions.exit),
      history_(9) {
  std::string config_error;
  steps_ = configuredSteps(config_error);
  buildMenus();
  CreateStatusBar(2);
  SetStatusText("No dataset open. File > Open (Ctrl+O) or File > Simulate.", 0);
  buildPanels();

  wxConfigBase* config = wxConfigBase::Get();
  config->SetPath("/RecentFiles");
  history_.Load(*config);
  config->SetPath("/");
  Bind(wxEVT_CLOSE_WINDOW, &MainFrame::onClose, this);
  validateSettings();
  if (!config_error.empty())
    log("error: the registration configuration cannot be read: " +
        wxString::FromUTF8(config_error) + "\nReinstall lookboth or fix the file named above.");
  // Sash positions need the window's real size: set them once it is shown.
  CallAfter([this] {
    outer_split_->SetSashPosition(300);
    right_split_->SetSashPosition(std::max(300, right_split_->GetClientSize().y - 250));
    views_->SetSashPosition(views_->GetClientSize().x * 42 / 100);
    bottom_split_->SetSashPosition(bottom_split_->GetClientSize().x * 64 / 100);
    startup_.next();
  });
}

MainFrame::~MainFrame() {
  runner_.requestStop();
  runner_.wait();
}

void MainFrame::onClose(wxCloseEvent& event) {
  if (runner_.running()) {
    log("Stopping the running job before closing...");
    runner_.requestStop();
  }
  runner_.wait();
  wxConfigBase* config = wxConfigBase::Get();
  config->SetPath("/RecentFiles");
  history_.Save(*config);
  config->SetPath("/");
  config->Flush();
  if (startup_.actions().on_close) startup_.actions().on_close(exit_status_);
  event.Skip();
}

// ---- building the window ----

void MainFrame::buildPanels() {
  outer_split_ = new wxSplitterWindow(this, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                                      wxSP_LIVE_UPDATE | wxSP_3DSASH);
  // The settings and the pipeline, scrolled when the window is too short.
  left_ = new wxScrolledWindow(outer_split_, wxID_ANY, wxDefaultPosition, wxDefaultSize, wxVSCROLL);
  left_->SetScrollRate(0, 12);
  setup_ = new SetupPanel(left_, {[this] { validateSettings(); }, [this] { applyMarker(); },
                                  [this](const wxString& line) { log(line); }});
  pipeline_panel_ =
      new PipelinePanel(left_, steps_,
                        {[this](int step) { runStep(step, {}); }, [this] { runAll(); },
                         [this] { runNext(); }, [this] { cancelJob(); }});
  auto* left_sizer = new wxBoxSizer(wxVERTICAL);
  left_sizer->Add(setup_, 0, wxEXPAND);
  left_sizer->Add(pipeline_panel_, 0, wxEXPAND);
  left_sizer->AddStretchSpacer();
  left_->SetSizer(left_sizer);

  right_split_ = new wxSplitterWindow(outer_split_, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                                      wxSP_LIVE_UPDATE | wxSP_3DSASH);
  auto on_select = [this](const std::string& label) { selectCamera(label); };
  views_ = new ViewsPanel(right_split_, on_select);
  bottom_split_ = new wxSplitterWindow(right_split_, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                                       wxSP_LIVE_UPDATE | wxSP_3DSASH);
  table_ = new CameraTable(bottom_split_, on_select);
  log_ = new wxTextCtrl(bottom_split_, wxID_ANY, "", wxDefaultPosition, wxDefaultSize,
                        wxTE_MULTILINE | wxTE_READONLY | wxTE_RICH2);
  bottom_split_->SplitVertically(table_, log_, 0);
  bottom_split_->SetSashGravity(0.6);
  bottom_split_->SetMinimumPaneSize(200);
  right_split_->SplitHorizontally(views_, bottom_split_, -260);
  right_split_->SetSashGravity(1.0);
  right_split_->SetMinimumPaneSize(120);
  outer_split_->SplitVertically(left_, right_split_, 300);
  outer_split_->SetMinimumPaneSize(220);
}

wxMenu* MainFrame::buildFileMenu() {
  auto* file = new wxMenu;
  file->Append(wxID_OPEN, "&Open dataset...\tCtrl+O",
               "Open a lookboth dataset (.rawlog) or folder");
  file->Append(kIdOpenFolder, "Open &folder dataset...\tCtrl+Shift+O",
               "Open a dataset in the plain folder layout (doc/formats.md)");
  file->Append(kIdImportBag, "&Import ROS bag...\tCtrl+I",
               "Convert a ROS 1 or ROS 2 bag to a dataset with a topic mapping file, then open it");
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
  auto* formats = new wxMenu;
  const char* format_titles[] = {
      "&COLMAP text model...", "&JSON...", "&OpenCV YAML, one file per camera...",
      "&ROS 2: URDF, static transforms, camera_info...", "&MRPT pose graph..."};
  const std::vector<ExportFormat> all_formats = allExportFormats();
  for (std::size_t i = 0; i < all_formats.size(); ++i) {
    formats->Append(kIdExportFormatFirst + static_cast<int>(i), format_titles[i]);
  }
  formats->Append(kIdExportFormatFirst + static_cast<int>(all_formats.size()),
                  "&All formats, a folder each...");
  file->AppendSubMenu(formats, "Export for &other systems");
  auto* site = new wxMenu;
  site->Append(kIdAlignFloor, "In the &floor frame...",
               "Write the registration with z normal to the floor the robot drove on");
  site->Append(kIdAlignControlPoints, "In the &site frame (control points)...",
               "Write the registration in the frame of surveyed camera positions (CSV)");
  site->Append(kIdAlignControlPointsScaled, "In the site frame, with its s&cale (Sim(3))...",
               "The same with the scale from the control points too (4 or more)");
  file->AppendSubMenu(site, "Site &frame");
  file->Append(kIdCheckAgainst, "&Check against the record...",
               "Which cameras moved since the registration on record (lookboth check)");
  file->Append(kIdUpdateRecord, "&Update the record with this drive...",
               "Register the moved and new cameras against the record, the others held at it "
               "(lookboth register --update)");
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
  return file;
}

wxMenu* MainFrame::buildPipelineMenu() {
  auto* pipeline = new wxMenu;
  pipeline->Append(kIdRunAll, "Run &all stages\tF5", "Run every step not run yet");
  pipeline->Append(kIdRunNext, "Run &next stage\tF6", "Run the first step not run yet");
  pipeline->AppendSeparator();
  for (size_t i = 0; i < steps_.size(); ++i) {
    wxString item =
        wxString::Format("&%zu %s", i + 1, wxString::FromUTF8(studio::stepTitle(steps_[i].name)));
    if (i < 9) item += wxString::Format("\tAlt+%zu", i + 1);
    pipeline->Append(kIdStepFirst + static_cast<int>(i), item,
                     wxString::FromUTF8("Run the step '" + steps_[i].name +
                                        "' (once the steps before it have run)"));
  }
  pipeline->AppendSeparator();
  pipeline->Append(kIdCancel, "&Cancel\tEsc");
  return pipeline;
}

void MainFrame::buildMenus() {
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

  pipeline_menu_ = buildPipelineMenu();
  auto* bar = new wxMenuBar;
  bar->Append(buildFileMenu(), "&File");
  bar->Append(pipeline_menu_, "&Pipeline");
  bar->Append(view, "&View");
  bar->Append(help, "&Help");
  SetMenuBar(bar);
  bindMenus();
}

void MainFrame::bindMenus() {
  auto on = [this](int id, std::function<void()> action) {
    Bind(
        wxEVT_MENU, [action](wxCommandEvent&) { action(); }, id);
  };
  on(wxID_OPEN, [this] {
    wxFileDialog dialog(this, "Open a lookboth dataset", "", "",
                        "lookboth datasets (*.rawlog;*.yaml)|*.rawlog;*.yaml|All files|*",
                        wxFD_OPEN | wxFD_FILE_MUST_EXIST);
    if (dialog.ShowModal() == wxID_OK) openDataset(dialog.GetPath().ToStdString(), {});
  });
  on(kIdOpenFolder, [this] {
    wxDirDialog dialog(this, "Open a folder dataset", "", wxDD_DIR_MUST_EXIST);
    if (dialog.ShowModal() == wxID_OK) openDataset(dialog.GetPath().ToStdString(), {});
  });
  on(kIdImportBag, [this] { importBag(); });
  const auto scenarios = sim::builtinScenarioNames();
  Bind(
      wxEVT_MENU,
      [this, scenarios](wxCommandEvent& e) {
        const size_t i = static_cast<size_t>(e.GetId() - kIdSimulateFirst);
        if (i < scenarios.size()) simulateScenario(scenarios[i], false, "", 0, {});
      },
      kIdSimulateFirst, kIdSimulateLast);
  Bind(
      wxEVT_MENU,
      [this](wxCommandEvent& e) {
        const wxString path = history_.GetHistoryFile(static_cast<size_t>(e.GetId() - wxID_FILE1));
        if (!path.empty()) openDataset(path.ToStdString(), {});
      },
      wxID_FILE1, wxID_FILE9);
  Bind(
      wxEVT_MENU,
      [this](wxCommandEvent& e) {
        const int step = e.GetId() - kIdStepFirst;
        if (step >= 0 && step < static_cast<int>(steps_.size())) runStep(step, {});
      },
      kIdStepFirst, kIdStepLast);
  Bind(
      wxEVT_MENU, [this](wxCommandEvent& e) { saveViewScreenshot(e.GetId() - kIdViewShotFirst); },
      kIdViewShotFirst, kIdViewShotLast);
  on(kIdScreenshot, [this] { chooseAndSaveScreenshot(); });
  on(wxID_EXIT, [this] { Close(); });
  on(kIdRunAll, [this] { runAll(); });
  on(kIdRunNext, [this] { runNext(); });
  on(kIdExportReport, [this] { chooseAndExportReport(); });
  on(kIdExportRegistration, [this] { chooseAndExportRegistration(); });
  const std::vector<ExportFormat> formats = allExportFormats();
  for (std::size_t i = 0; i <= formats.size(); ++i) {
    const std::string name = i < formats.size() ? exportFormatName(formats[i]) : "all";
    on(kIdExportFormatFirst + static_cast<int>(i), [this, name] { chooseAndExportFormats(name); });
  }
  on(kIdAlignFloor, [this] { chooseAndAlign(true); });
  on(kIdCheckAgainst, [this] { chooseAndCheck(); });
  on(kIdUpdateRecord, [this] { chooseAndUpdate(); });
  on(kIdAlignControlPoints, [this] { chooseAndAlign(false); });
  on(kIdAlignControlPointsScaled, [this] { chooseAndAlign(false, true); });
  on(kIdCycleOverlay, [this] { views_->cycleOverlay(); });
  on(kIdLoadCalibration, [this] { chooseAndLoadCalibration(); });
  on(kIdCancel, [this] { cancelJob(); });
  on(kIdTopView, [this] { views_->scene()->topView(); });
  on(kIdSideView, [this] { views_->scene()->sideView(); });
  on(kIdFitView, [this] { views_->scene()->fitView(); });
  on(kIdNextFrame, [this] { views_->nextFrame(); });
  on(kIdPrevFrame, [this] { views_->previousFrame(); });
  on(wxID_ABOUT, [this] { showAbout(); });
}

// ---- jobs ----

void MainFrame::log(const wxString& line) {
  log_->AppendText(line + "\n");
  // Unattended runs (--exit) also print the log, for scripts and tests.
  if (unattended_) std::fprintf(stderr, "%s\n", line.utf8_str().data());
}

void MainFrame::fail(const wxString& text, const wxString& title) {
  log("error: " + text);
  if (unattended_)
    exit_status_ = 1;
  else
    wxMessageBox(text, title, wxOK | wxICON_WARNING, this);
}

bool MainFrame::startJob(const std::string& name, studio::JobRunner::Job job, Then then) {
  if (runner_.running()) {
    wxMessageBox("A job is already running. Wait for it or cancel it (Esc).", "lookboth studio",
                 wxOK | wxICON_INFORMATION, this);
    return false;
  }
  log("> " + wxString::FromUTF8(name));
  pipeline_panel_->jobStarted(name);
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
  const wxString line = pipeline_panel_->jobProgress(e);
  if (!line.empty()) log(line);
}

void MainFrame::onJobDone(const studio::JobResult& r, const Then& then) {
  runner_.wait();
  const wxString summary = wxString::Format("%s %s in %.1f s", wxString::FromUTF8(r.name),
                                            studio::jobStatusName(r.status), r.seconds);
  pipeline_panel_->jobEnded(summary, r.status == studio::JobStatus::kSucceeded);
  log("  " + summary);
  const int step = running_step_;
  running_step_ = -1;
  // A registration stage that failed or stopped may have left part of its
  // work in the kept problem: the registration stages start over.
  if (r.status != studio::JobStatus::kSucceeded && steps_.isStage(step) && step_runner_) {
    resetSteps(true);
    log("  the registration stages will start again from the first one");
  }
  validateSettings();
  if (r.status == studio::JobStatus::kFailed) {
    exit_status_ = 1;
    log("  error: " + wxString::FromUTF8(r.message));
    if (unattended_)
      CallAfter([this] { startup_.next(); });
    else
      wxMessageBox(wxString::FromUTF8(r.message) +
                       "\n\nFix the input named above (file, line or camera) and run again.",
                   wxString::FromUTF8(r.name) + " failed", wxOK | wxICON_ERROR, this);
    return;
  }
  if (r.status == studio::JobStatus::kStopped) {
    if (unattended_) exit_status_ = 1;
    return;
  }
  if (then) then();
}

void MainFrame::cancelJob() {
  if (runner_.running()) {
    log("Cancelling...");
    runner_.requestStop();
  }
}

// ---- the dataset ----

void MainFrame::openDataset(const std::string& path, Then then) {
  startJob(
      "open " + fs::path(path).filename().string(),
      [this, path](const ProgressReporter& progress) {
        auto index = std::make_shared<const studio::DatasetIndex>(
            studio::DatasetIndex::build(path, progress));
        CallAfter([this, index] { datasetLoaded(index); });
      },
      [this, path, then] {
        history_.AddFileToHistory(wxString::FromUTF8(path));
        if (then) then();
      });
}

void MainFrame::simulateScenario(const std::string& scenario, bool detections_only, std::string out,
                                 double duration_s, Then then) {
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
    fail(wxString::FromUTF8(problem), "Cannot simulate");
    if (then) CallAfter(then);  // the unattended startup goes on (without a dataset)
    return;
  }
  startJob(
      "simulate " + scenario,
      [options](const ProgressReporter& progress) { sim::simulate(options, progress); },
      [this, out, then] { openDataset(out, then); });
}

void MainFrame::importBag() {
  // A ROS 2 bag folder is opened by its metadata.yaml.
  wxFileDialog bag_dialog(this, "ROS bag to import", "", "",
                          "ROS bags (*.bag;*.mcap;*.db3;metadata.yaml)|*.bag;*.mcap;*.db3;"
                          "metadata.yaml|All files|*",
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
      [this, out] { openDataset(out, {}); });
}

void MainFrame::forgetRegistration() {
  registration_.reset();
  registration_view_.reset();
  rays_.clear();
  registration_dir_.clear();
  resetSteps(false);
}

void MainFrame::applyMarker() {
  if (!index_) return;
  const MarkerSpec marker = setup_->marker();
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
        forgetRegistration();
        log(wxString::FromUTF8("  marker " + marker.dictionary + " id " +
                               std::to_string(marker.id) + ", " + formatDouble(marker.size_m) +
                               " m written into the dataset; detections made for the old "
                               "marker stay until detection runs again (lookboth detect)"));
        datasetLoaded(*index);
      });
}

void MainFrame::chooseAndLoadCalibration() {
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
        forgetRegistration();
        log(wxString::FromUTF8("  " + label + ": calibration from " + file +
                               "; detections made with the old model stay until detection "
                               "runs again (lookboth detect)"));
        datasetLoaded(*index);
        if (then) then();
      });
}

// ---- the pipeline, one step per job ----

void MainFrame::resetSteps(bool keep_preparation) {
  steps_.reset(keep_preparation);
  step_runner_.reset();
  refreshSteps();
}

void MainFrame::refreshSteps() {
  const bool idle = !runner_.running();
  const bool ready = index_ && settings_ok_ && idle;
  pipeline_panel_->showSteps(steps_, running_step_, ready, index_ != nullptr);
  const int next = steps_.firstPending();
  for (size_t i = 0; i < steps_.size(); ++i)
    pipeline_menu_->Enable(kIdStepFirst + static_cast<int>(i),
                           ready && static_cast<int>(i) == next);
  pipeline_menu_->Enable(kIdRunAll, ready);
  pipeline_menu_->Enable(kIdRunNext, ready && next >= 0);
  GetMenuBar()->Enable(kIdExportReport, idle && !registration_dir_.empty());
  GetMenuBar()->Enable(kIdExportRegistration, idle && registration_ != nullptr);
  for (int id = kIdExportFormatFirst; id <= kIdExportFormatFirst + 5; ++id) {
    GetMenuBar()->Enable(id, idle && registration_ != nullptr);
  }
  GetMenuBar()->Enable(kIdAlignFloor, idle && registration_ != nullptr);
  GetMenuBar()->Enable(kIdAlignControlPoints, idle && registration_ != nullptr);
  GetMenuBar()->Enable(kIdAlignControlPointsScaled, idle && registration_ != nullptr);
  GetMenuBar()->Enable(kIdCheckAgainst, idle && registration_ != nullptr);
  GetMenuBar()->Enable(kIdUpdateRecord, idle && !registration_dir_.empty() && step_runner_);
}

void MainFrame::validateSettings() {
  settings_ok_ = setup_->validate(index_.get(), !runner_.running());
  refreshSteps();
  left_->Layout();
  left_->FitInside();
}

FullPipelineOptions MainFrame::pipelineOptions() const {
  FullPipelineOptions options;
  options.dataset = index_->path();
  const fs::path dataset(index_->path());
  options.out = dataset.parent_path() / (dataset.stem().string() + "_registration");
  options.overwrite = true;
  options.mode = setup_->trajectoryMode();
  options.trajectory_label = setup_->trajectoryLabel();
  // The panel's settings, over default.yaml (and the startup's --config), in memory.
  options.config_overrides = setup_->settingsYaml();
  return options;
}

void MainFrame::runAll() {
  if (!index_) {
    wxMessageBox("Open or simulate a dataset first (File menu).", "lookboth studio",
                 wxOK | wxICON_INFORMATION, this);
    return;
  }
  // Everything has run: run the registration stages again (with the current settings).
  if (steps_.allDone()) resetSteps(true);
  runSteps(static_cast<int>(steps_.size()) - 1, {});
}

void MainFrame::runNext() {
  const int step = steps_.firstPending();
  if (step >= 0) runStep(step, {});
}

void MainFrame::runSteps(int last, Then done) {
  const int next = steps_.firstPending();
  if (next < 0 || next > last) {
    if (done) done();
    return;
  }
  runStep(next, [this, last, done] { runSteps(last, done); });
}

void MainFrame::runStep(int step, Then then) {
  if (!index_) {
    wxMessageBox("Open or simulate a dataset first (File menu).", "lookboth studio",
                 wxOK | wxICON_INFORMATION, this);
    return;
  }
  if (step < 0 || step >= static_cast<int>(steps_.size())) return;
  if (step != steps_.firstPending()) {
    wxMessageBox("Run the steps before it first (Pipeline menu, F6 runs the next one).",
                 "lookboth studio", wxOK | wxICON_INFORMATION, this);
    return;
  }
  validateSettings();
  if (!settings_ok_) {
    fail("Fix the settings marked in red first.", "lookboth studio");
    if (unattended_) CallAfter([this] { startup_.next(); });
    return;
  }
  // A new controller for detection and for the first registration stage
  // (with the settings as they are then): it skips what the dataset has.
  const FullPipelineOptions options = pipelineOptions();
  if (step == 0 || step == studio::PipelineSteps::kPreparationSteps || !step_runner_)
    step_runner_ = std::make_shared<studio::StepRunner>(options);
  auto result = std::make_shared<studio::StepResult>();
  const std::string name = steps_[static_cast<size_t>(step)].name;
  studio::JobRunner::Job job = [runner = step_runner_, step, name,
                                result](const ProgressReporter& progress) {
    *result = runner->run(step, name, progress);
  };
  running_step_ = step;
  const fs::path out = options.out;
  const bool started =
      startJob(studio::stepTitle(name), std::move(job), [this, step, result, out, then] {
        if (result->index) datasetLoaded(result->index);
        if (result->registration) {
          if (result->written) registration_dir_ = out;
          registrationReady(result->registration, std::move(result->rays));
        }
        stepFinished(step, result->outcome);
        if (then) then();
      });
  if (!started) running_step_ = -1;
}

void MainFrame::stepFinished(int step, const StepOutcome& outcome) {
  steps_.finish(step, outcome.ran, outcome.summary);
  log("  " + wxString::FromUTF8(outcome.summary));
  refreshSteps();
}

// ---- what the panels show ----

void MainFrame::registrationReady(std::shared_ptr<const Registration> registration,
                                  std::vector<DetectionRay> rays) {
  registration_ = std::move(registration);
  registration_view_ = std::make_shared<const report::RegistrationView>(
      report::viewOfRegistration(*registration_, "registration"));
  rays_ = std::move(rays);
  table_->showCheck(nullptr);  // a check was of the registration before this one
  // Stage by stage, the same messages come again: each is logged once.
  auto once = [this](const std::string& line) {
    if (logged_.insert(line).second) log("  " + wxString::FromUTF8(line));
  };
  for (const auto& w : registration_->labelledWarnings()) once("warning: " + w);
  // One sentence per line: the statement is long.
  if (!registration_->observability.message.empty())
    once("observability:\n" +
         wrapSentences(registration_->observability.message, "    ", kNoWidth));
  datasetLoaded(index_);
}

void MainFrame::datasetLoaded(std::shared_ptr<const studio::DatasetIndex> index) {
  const bool new_dataset = !index_ || index_->path() != index->path();
  index_ = std::move(index);
  if (new_dataset) {
    // Another dataset: nothing has run on it yet.
    forgetRegistration();
    logged_.clear();
  }
  setup_->showDataset(*index_, new_dataset, startup_.actions().trajectory);
  SetTitle(wxString::FromUTF8("lookboth studio - " + index_->manifest().name));
  SetStatusText(wxString::FromUTF8(index_->path().string()), 0);
  const auto notes = std::count_if(index_->issues().begin(), index_->issues().end(),
                                   [](const DatasetIssue& issue) { return issue.note; });
  SetStatusText(wxString::Format("%zu input issues", index_->issues().size() - notes), 1);
  for (const auto& issue : index_->issues()) {
    log(wxString::FromUTF8((issue.note ? "  note: " : "  warning: ") + issue.where + ": " +
                           issue.message));
  }
  validateSettings();
  table_->show(index_, registration_);
  views_->show({index_, registration_, registration_view_, rays_});
  const auto rows = index_->cameraSummaries();
  if (selected_.empty() && !rows.empty()) {
    auto most_detected =
        std::max_element(rows.begin(), rows.end(),
                         [](const auto& a, const auto& b) { return a.detections < b.detections; });
    selectCamera(most_detected->label);
  }
}

void MainFrame::selectCamera(const std::string& label) {
  if (label == selected_) return;
  selected_ = label;
  table_->setSelected(label);
  views_->setSelected(label);
  SetStatusText(wxString::FromUTF8("selected " + label), 1);
}

// ---- out of the window ----

void MainFrame::exportRegistration(const std::string& dir) {
  if (!registration_) {
    fail("no registration to export yet: run the stages first", "Registration not exported");
    return;
  }
  RegistrationRun run;
  run.registration = *registration_;
  run.rays = rays_;
  try {
    writeRegistrationOutput(run, dir, true);
  } catch (const Error& e) {
    fail(wxString::FromUTF8(e.what()) +
             "\n\nChoose a folder whose parent exists and that you can write to.",
         "Registration not exported");
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

void MainFrame::exportFormats(const std::string& formats, const std::string& dir) {
  if (!registration_ || !index_) {
    fail("no registration to export yet: run the stages first", "Nothing exported");
    return;
  }
  try {
    const std::vector<ExportFormat> chosen = parseExportFormats(formats);
    std::vector<MarkerObservation> detections;
    for (const CameraSensor& sensor : index_->manifest().cameras) {
      const std::vector<MarkerObservation>& markers = index_->markers(sensor.label);
      detections.insert(detections.end(), markers.begin(), markers.end());
    }
    const ExportSources sources = exportSources(index_->manifest(), detections);
    for (const std::string& line :
         exportRegistrationFormats(*registration_, sources, dir, chosen, ExportOptions{})) {
      log(wxString::FromUTF8(line));
    }
    log("Exported to " + wxString::FromUTF8(dir));
  } catch (const std::exception& e) {
    fail(wxString::FromUTF8(e.what()), "Not exported");
  }
}

void MainFrame::chooseAndExportFormats(const std::string& formats) {
  if (!registration_) return;
  wxDirDialog dialog(this, "Folder to export into (created or replaced)");
  if (dialog.ShowModal() == wxID_OK) exportFormats(formats, dialog.GetPath().ToStdString());
}

void MainFrame::writeAligned(const AlignedRegistration& aligned, const std::string& dir) {
  for (const std::string& line : aligned.summary) log(wxString::FromUTF8(line));
  writeDirectoryAtomically(dir, [&](const std::filesystem::path& folder) {
    saveRegistration(aligned.registration, folder);
  });
  log("Registration in the " + wxString::FromUTF8(aligned.registration.world_frame.name) +
      " frame written to " + wxString::FromUTF8(dir));
}

void MainFrame::alignToFloor(const std::string& dir) {
  if (!registration_) {
    fail("no registration yet: run the stages first", "Not aligned");
    return;
  }
  try {
    writeAligned(alignRegistrationToFloor(*registration_), dir);
  } catch (const std::exception& e) {
    fail(wxString::FromUTF8(e.what()), "Not aligned");
  }
}

void MainFrame::logMoved(const FacilityCheck& check, const std::string& then) {
  for (const CameraCheck& c : check.cameras) {
    if (c.verdict != CameraVerdict::kMoved) continue;
    log(wxString::FromUTF8("  " + c.label + " moved " + formatFixed(c.moved_m.norm() * 1000, 1) +
                           " mm, " + formatFixed(c.rotated_deg, 3) + " deg" + then));
  }
}

void MainFrame::checkAgainst(const std::string& record) {
  if (!registration_) {
    fail("no registration yet: run the stages first", "Not checked");
    return;
  }
  try {
    auto check = std::make_shared<const FacilityCheck>(
        checkFacility(*registration_, loadRegistration(record, {false})));
    log(wxString::Format("check against %s: %d moved, %d unchanged, %d not seen, %d new",
                         wxString::FromUTF8(record), check->moved, check->unchanged,
                         check->not_seen, check->added));
    logMoved(*check, "");
    SetStatusText(wxString::Format("%d camera(s) moved since the record", check->moved), 1);
    table_->showCheck(std::move(check));
  } catch (const std::exception& e) {
    fail(wxString::FromUTF8(e.what()), "Not checked");
  }
}

void MainFrame::chooseAndCheck() {
  if (!registration_) {
    fail("no registration yet: run the stages first", "Not checked");
    return;
  }
  wxDirDialog dialog(this, "The registration on record (a registration folder)", "",
                     wxDD_DEFAULT_STYLE | wxDD_DIR_MUST_EXIST);
  if (dialog.ShowModal() != wxID_OK) return;
  checkAgainst(dialog.GetPath().ToStdString());
}

void MainFrame::startUpdate(const std::string& record, const std::string& out, Then then) {
  if (registration_dir_.empty() || !step_runner_) {
    fail("run every step of the pipeline first", "Not updated");
    if (unattended_ && then) CallAfter(then);
    return;
  }
  // By default beside the registration, named after it.
  const std::string target = out.empty() ? registration_dir_.string() + "_updated" : out;
  auto result = std::make_shared<studio::StepResult>();
  studio::JobRunner::Job job = [runner = step_runner_, record, target,
                                result](const ProgressReporter& progress) {
    *result = runner->updateRecord(record, target, progress);
  };
  startJob("Update the record", std::move(job), [this, result, target, then] {
    registration_dir_ = target;
    registrationReady(result->registration, std::move(result->rays));
    log("  " + wxString::FromUTF8(result->outcome.summary));
    logMoved(*result->check, ": registered again against the record");
    SetStatusText(wxString::Format("record updated: %d camera(s) moved", result->check->moved), 1);
    table_->showCheck(result->check);
    refreshSteps();
    if (then) then();
  });
}

void MainFrame::updateRecord(const std::string& record, const std::string& out) {
  startUpdate(record, out, [this] { startup_.next(); });
}

void MainFrame::chooseAndUpdate() {
  if (registration_dir_.empty()) return;
  wxDirDialog dialog(this, "The registration on record to update (a registration folder)", "",
                     wxDD_DEFAULT_STYLE | wxDD_DIR_MUST_EXIST);
  if (dialog.ShowModal() != wxID_OK) return;
  startUpdate(dialog.GetPath().ToStdString(), "", nullptr);
}

void MainFrame::chooseAndAlign(bool floor, bool with_scale) {
  if (!registration_) return;
  std::string points;
  if (!floor) {
    wxFileDialog open(this,
                      "Control points (CSV name,x,y,z,sigma_m; name a camera, @start, @end "
                      "or @<unix seconds> for the robot's position then, or marker:<id> for "
                      "a marker on the floor the cameras saw)",
                      "", "", "CSV files (*.csv)|*.csv|All files|*",
                      wxFD_OPEN | wxFD_FILE_MUST_EXIST);
    if (open.ShowModal() != wxID_OK) return;
    points = open.GetPath().ToStdString();
  }
  wxDirDialog dialog(this, "Folder to write the aligned registration into (created or replaced)");
  if (dialog.ShowModal() != wxID_OK) return;
  const std::string dir = dialog.GetPath().ToStdString();
  if (floor) {
    alignToFloor(dir);
    return;
  }
  try {
    SiteAlignmentOptions options;
    options.with_scale = with_scale;
    // Fixed markers ("marker:<id>" points) located from the index's detections.
    const LocatedPoints markers = index_
                                      ? locateFixedMarkers(*registration_, index_->fixedMarkers(),
                                                           index_->manifest().marker.id)
                                      : LocatedPoints{};
    writeAligned(alignRegistrationToControlPoints(*registration_, points, options, markers), dir);
  } catch (const std::exception& e) {
    fail(wxString::FromUTF8(e.what()), "Not aligned");
  }
}

void MainFrame::exportReport(const std::string& path, Then then) {
  if (registration_dir_.empty() || !index_) {
    fail("The report needs a finished registration: run every stage first (F5).",
         "lookboth studio");
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

void MainFrame::saveScreenshot(const std::string& path) {
  Raise();
  Update();
  const wxRect rect = GetScreenRect();
  const wxBitmap bitmap = grabScreen(rect);
  const fs::path target(path);
  if (!savePng(bitmap.ConvertToImage(), target)) {
    log("error: cannot write " + wxString::FromUTF8(path));
    exit_status_ = 1;
    return;
  }
  log("Screenshot saved: " + wxString::FromUTF8(path));
  // One picture per view beside it (<name>-scene.png, -fisheye.png, -table.png),
  // so that each can be checked or put in a document on its own.
  const std::pair<wxWindow*, const char*> parts[] = {{views_->scene(), "scene"},
                                                     {views_->fisheyeView(), "fisheye"},
                                                     {views_->cameraView(), "camera"},
                                                     {table_, "table"}};
  for (const auto& [window, name] : parts) {
    const fs::path part =
        target.parent_path() / (target.stem().string() + "-" + name + target.extension().string());
    // The image views draw themselves off screen (the hidden tab too).
    if (window == views_->fisheyeView() || window == views_->cameraView()) {
      const wxImage image = static_cast<ImageView*>(window)->render(
          views_->imageTabs()->GetCurrentPage()->GetClientSize());
      if (image.IsOk()) image.SaveFile(wxString::FromUTF8(part.string()), wxBITMAP_TYPE_PNG);
      continue;
    }
    if (!window->IsShownOnScreen()) continue;
    wxRect r = window->GetScreenRect();
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
  if (view < 0 || view > 3) return;
  wxWindow* windows[] = {views_->scene(), views_->fisheyeView(), views_->cameraView(), table_};
  wxWindow* window = windows[view];
  // The image views live in tabs: show the one asked for.
  if (view == 1 || view == 2) views_->imageTabs()->SetSelection(view - 1);
  wxFileDialog dialog(this, "Save a screenshot of a view", "",
                      wxString("lookboth-") + kViewNames[view] + ".png", "PNG (*.png)|*.png",
                      wxFD_SAVE | wxFD_OVERWRITE_PROMPT);
  if (dialog.ShowModal() != wxID_OK) return;
  Raise();
  Update();
  const wxImage image = view == 1 || view == 2
                            ? static_cast<ImageView*>(window)->render()
                            : grabScreen(window->GetScreenRect()).ConvertToImage();
  const fs::path target(dialog.GetPath().ToStdString());
  if (!savePng(image, target)) {
    wxMessageBox("Cannot write " + wxString::FromUTF8(target.string()) +
                     ": choose a folder you can write to.",
                 "Screenshot not saved", wxOK | wxICON_ERROR, this);
    return;
  }
  log("Screenshot of the " + wxString(kViewNames[view]) +
      " view saved: " + wxString::FromUTF8(target.string()));
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

// ---- the unattended startup (studio::ScriptedStartup) ----

void MainFrame::simulate(const StartupActions& a) {
  simulateScenario(a.simulate, a.detections_only, a.simulate_out, a.duration_s,
                   [this] { startup_.next(); });
}

void MainFrame::open(const std::string& dataset) {
  openDataset(dataset, [this] { startup_.next(); });
}

void MainFrame::loadCalibration(const std::string& camera, const std::string& file) {
  loadCalibrationFor(camera, file, [this] { startup_.next(); });
}

void MainFrame::runThrough(int last_step) {
  runSteps(last_step, [this] { startup_.next(); });
}

void MainFrame::error(const std::string& message) {
  log("error: " + wxString::FromUTF8(message));
  exit_status_ = 1;
}

void MainFrame::show(int overlay_mode, const std::string& camera, int frame) {
  views_->setOverlay(overlay_mode);
  if (!camera.empty()) selectCamera(camera);
  views_->showFrame(frame >= 0 ? frame : views_->frame());
}

void MainFrame::exportReport(const std::string& path) {
  exportReport(path, [this] { startup_.next(); });
}

void MainFrame::finish(const std::string& screenshot, bool exit) {
  // Let the views (the OpenGL one in particular) draw before capturing.
  auto* timer = new wxTimer();
  timer->Bind(wxEVT_TIMER, [this, timer, screenshot, exit](wxTimerEvent&) {
    if (!screenshot.empty()) saveScreenshot(screenshot);
    timer->Stop();
    if (exit) Close(true);
    CallAfter([timer] { delete timer; });
  });
  timer->StartOnce(1500);
}

}  // namespace lookboth::studio_app
