// The main window of lookboth-studio. It owns the views and forwards every
// action to the libraries (dataset indexing, simulation, the pipeline) run
// by a JobRunner on a worker thread; it holds no estimation logic.
#pragma once

#include <wx/filehistory.h>
#include <wx/frame.h>

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "lookboth/pipeline/full_pipeline.h"
#include "lookboth/pipeline/registration_controller.h"
#include "lookboth/studio/dataset_index.h"
#include "lookboth/studio/job_runner.h"
#include "lookboth/studio/pipeline_steps.h"

class wxChoice;
class wxGauge;
class wxListCtrl;
class wxListEvent;
class wxRadioBox;
class wxSlider;
class wxSplitterWindow;
class wxSpinCtrl;
class wxStaticText;
class wxTextCtrl;
class wxButton;
class wxNotebook;
class wxMenu;

namespace lookboth::studio_app {

class ImageView;
class SceneView;

/// What the command line asks the app to do without a person (for tests and demos).
struct StartupActions {
  std::string open;      ///< Dataset to open.
  std::string simulate;  ///< Built-in scenario to simulate (then open).
  bool detections_only = false;
  std::string simulate_out;  ///< Where the simulation goes (default: a temporary folder).
  double duration_s = 0;     ///< Simulate only the first seconds (0 = all).
  bool run_all = false;      ///< Run the whole pipeline once the dataset is open.
  std::string run_until;     ///< Run the steps up to this one ("detect", "look_down"...).
  /// Calibration files to load first (camera label, file), as File > Load camera calibration.
  std::vector<std::pair<std::string, std::string>> calibrations;
  std::string trajectory;     ///< "visual" or "metric" (default: visual when there are frames).
  std::string select;         ///< Camera to select.
  int frame = -1;             ///< Fisheye frame to show (-1: automatic).
  std::string overlay;        ///< Fisheye overlay: "both" (default), "before" or "after".
  std::string export_report;  ///< Write the HTML report here (.html file or folder).
  std::string export_registration;  ///< Write the registration files into this folder.
  std::string screenshot;           ///< Save a screenshot of the window here when done.
  bool exit = false;                ///< Quit when done (exit status 1 if a job failed).
  /// Receives the exit status (0, or 1 when a job failed) when the window closes.
  std::function<void(int)> on_close;
};

class MainFrame : public wxFrame {
 public:
  using Then = std::function<void()>;
  explicit MainFrame(const StartupActions& actions);
  ~MainFrame() override;
  /// Exit status for --exit: 0, or 1 when a job failed.
  int exitStatus() const { return exit_status_; }

 private:
  // Building the window.
  void buildMenus();
  wxWindow* buildSetupPanel(wxWindow* parent);
  wxWindow* buildViews(wxWindow* parent);
  wxWindow* buildBottom(wxWindow* parent);

  // Actions.
  void openDataset(const std::string& path);
  void simulateScenario(const std::string& scenario, bool detections_only, std::string out,
                        double duration_s);
  void importBag();
  void runAll();
  void runNext();
  /// Runs the pipeline steps from the first pending one through step `last`
  /// (one job each, results shown as each ends), then `done`.
  void runThrough(int last, Then done);
  void runStep(int step, Then then);
  void stepFinished(int step, const StepOutcome& outcome);
  void resetSteps(bool keep_preparation);
  void refreshSteps();
  int firstPendingStep() const;
  int stepIndex(const std::string& name) const;
  /// Sets the trajectory controls as `lookboth register` would choose.
  void selectTrajectory();
  FullPipelineOptions pipelineOptions() const;
  /// The panel's settings as the YAML text of a configuration.
  std::string settingsYaml() const;
  void exportReport(const std::string& path, Then then);
  void chooseAndExportReport();
  void exportRegistration(const std::string& dir);
  void chooseAndExportRegistration();
  void saveViewScreenshot(int view);
  void cycleOverlay();
  void loadCalibration();
  void applyMarker();
  void loadCalibrationFor(const std::string& label, const std::string& file, Then then);
  void cancelJob();
  void saveScreenshot(const std::string& path);
  void chooseAndSaveScreenshot();
  void showAbout();

  bool startJob(const std::string& name, studio::JobRunner::Job job, Then then);
  void onJobProgress(const ProgressEvent& event);
  void onJobDone(const studio::JobResult& result, const Then& then);

  // Views.
  void datasetLoaded(std::shared_ptr<const studio::DatasetIndex> index);
  void registrationReady(std::shared_ptr<const studio::DatasetIndex> index,
                         std::shared_ptr<const Registration> registration,
                         std::vector<DetectionRay> rays, std::vector<std::string> steps);
  void refreshTable();
  void refreshScene();
  void showFisheyeFrame(int index);
  void showCameraView();
  void selectCamera(const std::string& label);
  void validateSettings();
  void log(const wxString& line);
  void continueStartup();

  StartupActions actions_;
  int startup_step_ = 0;
  size_t calibrations_done_ = 0;
  int exit_status_ = 0;

  studio::JobRunner runner_;
  std::shared_ptr<const studio::DatasetIndex> index_;
  std::shared_ptr<const Registration> registration_;
  std::shared_ptr<const void> registration_view_;  ///< report::RegistrationView (opaque here).
  std::filesystem::path registration_dir_;         ///< Where the finished registration was written.

  /// The pipeline's steps and what became of each (no window in it).
  studio::PipelineSteps steps_;
  /// Each step's title, button, status line and menu item.
  struct StepWidgets {
    std::string title;
    wxButton* button = nullptr;
    wxStaticText* status = nullptr;
    int menu_id = 0;
  };
  std::vector<StepWidgets> step_widgets_;
  /// The controller `lookboth register` runs (RegistrationPipeline), kept
  /// between the steps' jobs: made on the worker thread by the first job
  /// that needs it; only the running job touches it.
  struct PipelineHolder {
    std::unique_ptr<RegistrationPipeline> pipeline;
  };
  std::shared_ptr<PipelineHolder> pipeline_;
  bool chain_running_ = false;
  std::set<std::string> logged_;  ///< Messages logged once per dataset (warnings...).
  int overlay_mode_ = 0;          ///< 0: before and after, 1: after only, 2: before only.
  std::vector<DetectionRay> rays_;
  std::string selected_;
  std::string last_stage_;
  int last_percent_ = -1;

  wxFileHistory history_;
  // Setup panel.
  wxWindow* setup_panel_ = nullptr;
  wxSplitterWindow* views_split_ = nullptr;
  wxSplitterWindow* bottom_split_ = nullptr;
  wxStaticText* dataset_text_ = nullptr;
  wxChoice* dictionary_ = nullptr;
  wxSpinCtrl* marker_id_ = nullptr;
  wxTextCtrl* marker_size_ = nullptr;
  wxRadioBox* trajectory_mode_ = nullptr;
  wxChoice* trajectory_label_ = nullptr;
  wxTextCtrl* huber_ = nullptr;
  wxTextCtrl* cauchy_ = nullptr;
  wxTextCtrl* gate_ = nullptr;
  wxStaticText* validation_ = nullptr;  ///< Problems of the dataset itself (cameras).
  wxStaticText* marker_msg_ = nullptr;  ///< Validation messages next to their fields.
  wxStaticText* trajectory_msg_ = nullptr;
  wxStaticText* loss_msg_ = nullptr;
  bool settings_ok_ = false;
  int running_step_ = -1;
  wxButton* run_all_ = nullptr;
  wxButton* run_next_ = nullptr;
  wxButton* marker_apply_ = nullptr;
  wxChoice* overlay_choice_ = nullptr;
  wxMenu* pipeline_menu_ = nullptr;
  wxButton* cancel_ = nullptr;
  wxGauge* gauge_ = nullptr;
  wxStaticText* stage_text_ = nullptr;
  // Views.
  SceneView* scene_ = nullptr;
  wxNotebook* image_tabs_ = nullptr;
  ImageView* fisheye_view_ = nullptr;
  ImageView* camera_view_ = nullptr;
  wxSlider* frame_slider_ = nullptr;
  wxStaticText* frame_text_ = nullptr;
  wxListCtrl* table_ = nullptr;
  wxTextCtrl* log_ = nullptr;
  std::vector<std::string> table_labels_;
  int sort_column_ = 0;
  bool sort_ascending_ = true;
};

}  // namespace lookboth::studio_app
