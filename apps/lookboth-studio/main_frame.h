// The main window of lookboth-studio: the menus, and the wiring between
// the panels (settings, pipeline, views, camera table, log) and the jobs.
// Every action runs in the libraries (dataset indexing, simulation, the
// pipeline controller `lookboth register` runs) as a job on a worker
// thread (studio::JobRunner), one at a time; the window holds no
// estimation logic, and the step sequencing (studio::PipelineSteps,
// studio::StepRunner) and the unattended startup (studio::ScriptedStartup)
// are tested without it.
#pragma once

#include <wx/filehistory.h>
#include <wx/frame.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include "lookboth/pipeline/full_pipeline.h"
#include "lookboth/registration/site_frame.h"
#include "lookboth/studio/dataset_index.h"
#include "lookboth/studio/job_runner.h"
#include "lookboth/studio/pipeline_steps.h"
#include "lookboth/studio/scripted_startup.h"
#include "lookboth/studio/step_runner.h"

class wxMenu;
class wxMenuBar;
class wxScrolledWindow;
class wxSplitterWindow;
class wxTextCtrl;

namespace lookboth::report {
struct RegistrationView;
}

namespace lookboth::studio_app {

using studio::StartupActions;
class CameraTable;
class PipelinePanel;
class SetupPanel;
class ViewsPanel;

class MainFrame : public wxFrame, private studio::ScriptedStartup::Target {
 public:
  using Then = std::function<void()>;
  explicit MainFrame(const StartupActions& actions);
  ~MainFrame() override;
  /// Exit status for --exit: 0, or 1 when a job failed.
  int exitStatus() const { return exit_status_; }

 private:
  // Building the window.
  wxMenu* buildFileMenu();
  wxMenu* buildPipelineMenu();
  void buildMenus();
  void bindMenus();
  void buildPanels();
  void onClose(wxCloseEvent& event);

  // Jobs: one at a time, its progress in the pipeline panel and the log.
  bool startJob(const std::string& name, studio::JobRunner::Job job, Then then);
  void onJobProgress(const ProgressEvent& event);
  void onJobDone(const studio::JobResult& result, const Then& then);
  void cancelJob();
  void log(const wxString& line);
  /// A failure the person must see: a message box, or with --exit the exit status.
  void fail(const wxString& text, const wxString& title);

  // The dataset.
  void openDataset(const std::string& path, Then then);
  void simulateScenario(const std::string& scenario, bool detections_only, std::string out,
                        double duration_s, Then then);
  void importBag();
  void applyMarker();
  void chooseAndLoadCalibration();
  void loadCalibrationFor(const std::string& label, const std::string& file, Then then);
  /// The dataset changed under what ran on it: the registration and every step go.
  void forgetRegistration();

  // The pipeline, one step per job.
  void runAll();
  void runNext();
  /// Runs the steps from the first pending one through step `last` (one
  /// job each, results shown as each ends), then `done`.
  void runSteps(int last, Then done);
  void runStep(int step, Then then);
  void stepFinished(int step, const StepOutcome& outcome);
  void resetSteps(bool keep_preparation);
  void refreshSteps();
  void validateSettings();
  FullPipelineOptions pipelineOptions() const;

  // What the panels show.
  void datasetLoaded(std::shared_ptr<const studio::DatasetIndex> index);
  void registrationReady(std::shared_ptr<const Registration> registration,
                         std::vector<DetectionRay> rays);
  void selectCamera(const std::string& label);

  // Out of the window.
  void exportReport(const std::string& path, Then then);
  void chooseAndExportReport();
  void chooseAndExportRegistration();
  void chooseAndExportFormats(const std::string& formats);
  void chooseAndAlign(bool floor, bool with_scale = false);
  void saveScreenshot(const std::string& path);
  void chooseAndSaveScreenshot();
  void saveViewScreenshot(int view);
  void showAbout();

  // studio::ScriptedStartup::Target: what the unattended startup asks for.
  bool hasDataset() const override { return index_ != nullptr; }
  void simulate(const StartupActions& actions) override;
  void open(const std::string& dataset) override;
  void loadCalibration(const std::string& camera, const std::string& file) override;
  int stepIndex(const std::string& name) const override { return steps_.index(name); }
  int stepCount() const override { return static_cast<int>(steps_.size()); }
  std::string stepNames() const override { return steps_.names(); }
  void runThrough(int last_step) override;
  void error(const std::string& message) override;
  void show(int overlay_mode, const std::string& camera, int frame) override;
  void exportRegistration(const std::string& dir) override;
  void alignToFloor(const std::string& dir) override;
  void checkAgainst(const std::string& record) override;
  /// One log line per camera a check found moved, ending with `then`.
  void logMoved(const FacilityCheck& check, const std::string& then);
  void chooseAndCheck();
  void updateRecord(const std::string& record, const std::string& out) override;
  void startUpdate(const std::string& record, const std::string& out, Then then);
  void chooseAndUpdate();
  void exportFormats(const std::string& formats, const std::string& dir) override;
  void writeAligned(const AlignedRegistration& aligned, const std::string& dir);
  void exportReport(const std::string& path) override;
  void finish(const std::string& screenshot, bool exit) override;

  studio::ScriptedStartup startup_;
  bool unattended_ = false;  ///< --exit: no dialogs; the log also goes to stderr.
  int exit_status_ = 0;

  studio::JobRunner runner_;
  std::shared_ptr<const studio::DatasetIndex> index_;
  std::shared_ptr<const Registration> registration_;
  std::shared_ptr<const report::RegistrationView> registration_view_;
  std::vector<DetectionRay> rays_;
  std::filesystem::path registration_dir_;  ///< Where the finished registration was written.

  /// The pipeline's steps and what became of each.
  studio::PipelineSteps steps_;
  /// The controller's steps between jobs: made anew for detection and for
  /// the first registration stage (with the settings as they are then);
  /// only the running job touches it.
  std::shared_ptr<studio::StepRunner> step_runner_;
  int running_step_ = -1;
  bool settings_ok_ = false;
  std::set<std::string> logged_;  ///< Messages logged once per dataset (warnings...).
  std::string selected_;

  wxFileHistory history_;
  wxMenu* pipeline_menu_ = nullptr;
  wxScrolledWindow* left_ = nullptr;
  SetupPanel* setup_ = nullptr;
  PipelinePanel* pipeline_panel_ = nullptr;
  ViewsPanel* views_ = nullptr;
  CameraTable* table_ = nullptr;
  wxTextCtrl* log_ = nullptr;
  wxSplitterWindow* outer_split_ = nullptr;
  wxSplitterWindow* right_split_ = nullptr;
  wxSplitterWindow* bottom_split_ = nullptr;
};

}  // namespace lookboth::studio_app
