#include "lookboth/studio/scripted_startup.h"

#include <utility>

namespace lookboth::studio {

int overlayMode(const std::string& overlay) {
  if (overlay == "after") return 1;
  if (overlay == "before") return 2;
  return 0;
}

ScriptedStartup::ScriptedStartup(StartupActions actions, Target& target)
    : actions_(std::move(actions)), target_(target) {}

void ScriptedStartup::next() {
  for (;;) {
    switch (phase_) {
      case Phase::kOpen:
        phase_ = Phase::kCalibrations;
        if (openStep()) return;
        break;
      case Phase::kCalibrations:
        if (calibrationStep()) return;  // the next calibration, or the run, after it
        phase_ = Phase::kRun;
        break;
      case Phase::kRun:
        phase_ = Phase::kUpdate;
        if (runStep()) return;
        break;
      case Phase::kUpdate:
        phase_ = Phase::kShow;
        if (updateStep()) return;
        break;
      case Phase::kShow:
        phase_ = Phase::kFinish;
        if (showStep()) return;
        break;
      case Phase::kFinish:
        phase_ = Phase::kDone;
        if (!actions_.screenshot.empty() || actions_.exit)
          target_.finish(actions_.screenshot, actions_.exit);
        return;
      case Phase::kDone:
        return;
    }
  }
}

bool ScriptedStartup::openStep() {
  if (!actions_.simulate.empty()) {
    target_.simulate(actions_);
    return true;
  }
  if (!actions_.open.empty()) {
    target_.open(actions_.open);
    return true;
  }
  return false;
}

bool ScriptedStartup::calibrationStep() {
  // One job per calibration, before anything runs on the dataset.
  if (calibrations_done_ >= actions_.calibrations.size() || !target_.hasDataset()) return false;
  const auto& [camera, file] = actions_.calibrations[calibrations_done_++];
  target_.loadCalibration(camera, file);
  return true;
}

bool ScriptedStartup::runStep() {
  if ((!actions_.run_all && actions_.run_until.empty()) || !target_.hasDataset()) return false;
  const int last =
      actions_.run_all ? target_.stepCount() - 1 : target_.stepIndex(actions_.run_until);
  if (last < 0) {
    target_.error("--run-until: no step '" + actions_.run_until +
                  "' (steps: " + target_.stepNames() + ")");
    return false;
  }
  target_.runThrough(last);
  return true;
}

bool ScriptedStartup::updateStep() {
  if (actions_.update_record.empty() || !target_.hasDataset()) return false;
  target_.updateRecord(actions_.update_record, actions_.update_out);
  return true;
}

bool ScriptedStartup::showStep() {
  target_.show(overlayMode(actions_.overlay), actions_.select, actions_.frame);
  if (!actions_.export_registration.empty())
    target_.exportRegistration(actions_.export_registration);
  if (!actions_.align_floor.empty()) target_.alignToFloor(actions_.align_floor);
  if (!actions_.check_against.empty()) target_.checkAgainst(actions_.check_against);
  if (!actions_.export_formats.empty()) {
    target_.exportFormats(actions_.export_formats, actions_.export_formats_dir);
  }
  if (actions_.export_report.empty()) return false;
  target_.exportReport(actions_.export_report);
  return true;
}

}  // namespace lookboth::studio
