// The settings of a run, left of the views: the dataset's summary, the
// marker, the trajectory and the robust losses. Each setting is checked
// by the options that use it (MarkerSpec::check(), the stages' own read
// and check through loadRegistrationConfig), its message shown next to it;
// the settings reach the pipeline in memory (settingsYaml()).
#pragma once

#include <wx/panel.h>

#include <functional>
#include <string>
#include <vector>

#include "lookboth/dataset/manifest.h"
#include "lookboth/pipeline/registration_controller.h"
#include "lookboth/studio/dataset_index.h"

class wxChoice;
class wxRadioBox;
class wxSpinCtrl;
class wxStaticText;
class wxTextCtrl;
class wxButton;

namespace lookboth::studio_app {

class SetupPanel : public wxPanel {
 public:
  struct Callbacks {
    std::function<void()> changed;       ///< A setting was edited.
    std::function<void()> apply_marker;  ///< "Apply": write the marker into the dataset.
    std::function<void(const wxString&)> log;
  };
  SetupPanel(wxWindow* parent, Callbacks callbacks);

  /// Shows a dataset opened or read again; a new one also sets the marker
  /// and the trajectory as `lookboth register` would choose them
  /// (`trajectory`: the startup's "visual" or "metric" instead, "" none).
  void showDataset(const studio::DatasetIndex& index, bool new_dataset,
                   const std::string& trajectory);
  /// Checks every setting against `index` (null: none open) and shows the
  /// messages; whether the steps may run. `idle`: no job runs (the Apply button).
  bool validate(const studio::DatasetIndex* index, bool idle);

  MarkerSpec marker() const;
  TrajectoryMode trajectoryMode() const;
  std::string trajectoryLabel() const;
  /// The settings as the YAML text of a configuration over the defaults
  /// (and the startup's --config).
  std::string settingsYaml() const;

 private:
  void buildDatasetBox(wxSizer* sizer);
  void buildMarkerBox(wxSizer* sizer);
  void buildTrajectoryBox(wxSizer* sizer);
  void buildLossBox(wxSizer* sizer);
  void selectTrajectory(const studio::DatasetIndex& index, const std::string& trajectory);
  /// The losses, read by the stages' options: their problems, and each field marked.
  std::vector<std::string> checkLosses();

  Callbacks callbacks_;
  wxStaticText* dataset_text_ = nullptr;
  wxStaticText* validation_ = nullptr;  ///< Problems of the dataset itself (cameras).
  wxChoice* dictionary_ = nullptr;
  wxSpinCtrl* marker_id_ = nullptr;
  wxTextCtrl* marker_size_ = nullptr;
  wxButton* marker_apply_ = nullptr;
  wxStaticText* marker_msg_ = nullptr;
  wxRadioBox* trajectory_mode_ = nullptr;
  wxChoice* trajectory_label_ = nullptr;
  wxStaticText* trajectory_msg_ = nullptr;
  wxTextCtrl* huber_ = nullptr;
  wxTextCtrl* cauchy_ = nullptr;
  wxTextCtrl* gate_ = nullptr;
  wxStaticText* loss_msg_ = nullptr;
};

}  // namespace lookboth::studio_app
