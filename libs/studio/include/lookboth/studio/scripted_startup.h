// What the desktop app does without a person, from its command line (tests,
// demos, the screenshots in the docs): open or simulate a dataset, load
// calibrations, run the pipeline, choose what the views show, export, take
// a screenshot and quit. Each action runs when the one before it has ended,
// as a click would. No window in it: the window is a Target, so the order is
// tested without wx.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace lookboth::studio {

/// What the command line asks the app to do without a person.
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
  /// Write the registration re-expressed in its floor frame into this folder.
  std::string align_floor;
  /// Check the registration against the one on record in this folder (which cameras moved).
  std::string check_against;
  /// Update the record in this folder with the drive (File > Update the record), once the
  /// pipeline has run; written to update_out (default: beside the registration, "_updated").
  std::string update_record;
  std::string update_out;
  /// Export for other systems: formats ("colmap,ros", "all") and the folder.
  std::string export_formats;
  std::string export_formats_dir;
  std::string screenshot;  ///< Save a screenshot of the window here when done.
  bool exit = false;       ///< Quit when done (exit status 1 if a job failed).
  /// Receives the exit status (0, or 1 when a job failed) when the window closes.
  std::function<void(int)> on_close;
};

/// The fisheye overlay a startup asks for: 0 before and after, 1 after
/// only, 2 before only (as the View menu cycles them).
int overlayMode(const std::string& overlay);

class ScriptedStartup {
 public:
  /// What the window does for the script. The asynchronous actions (they
  /// start a job) call ScriptedStartup::next() when their job has ended.
  class Target {
   public:
    virtual ~Target() = default;
    virtual bool hasDataset() const = 0;
    virtual void simulate(const StartupActions& actions) = 0;  ///< Then opens it; async.
    virtual void open(const std::string& dataset) = 0;         ///< Async.
    virtual void loadCalibration(const std::string& camera,
                                 const std::string& file) = 0;  ///< Async.
    /// Index of the pipeline step named `name` (-1: none), and the names for messages.
    virtual int stepIndex(const std::string& name) const = 0;
    virtual int stepCount() const = 0;
    virtual std::string stepNames() const = 0;
    virtual void runThrough(int last_step) = 0;  ///< Async.
    /// A mistake in the command line: said, and the exit status is 1.
    virtual void error(const std::string& message) = 0;
    /// The views: overlay mode, camera to select ("" none), frame (-1 automatic).
    virtual void show(int overlay_mode, const std::string& camera, int frame) = 0;
    virtual void exportRegistration(const std::string& dir) = 0;
    virtual void alignToFloor(const std::string& dir) = 0;
    virtual void checkAgainst(const std::string& record) = 0;
    virtual void updateRecord(const std::string& record, const std::string& out) = 0;  ///< Async.
    virtual void exportFormats(const std::string& formats, const std::string& dir) = 0;
    virtual void exportReport(const std::string& path) = 0;  ///< Async.
    /// The last action: a screenshot ("" none), then quit when `exit`.
    virtual void finish(const std::string& screenshot, bool exit) = 0;
  };

  ScriptedStartup(StartupActions actions, Target& target);

  const StartupActions& actions() const { return actions_; }
  /// Starts the next action (the first on the first call); nothing once all have run.
  void next();
  bool done() const { return phase_ == Phase::kDone; }

 private:
  enum class Phase { kOpen, kCalibrations, kRun, kUpdate, kShow, kFinish, kDone };
  /// Each returns whether it started an asynchronous action (next() then waits for it).
  bool openStep();
  bool calibrationStep();
  bool runStep();
  bool updateStep();
  bool showStep();

  StartupActions actions_;
  Target& target_;
  Phase phase_ = Phase::kOpen;
  std::size_t calibrations_done_ = 0;
};

}  // namespace lookboth::studio
