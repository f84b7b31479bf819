#include "setup_panel.h"

#include <yaml-cpp/yaml.h>

#include <wx/button.h>
#include <wx/choice.h>
#include <wx/radiobox.h>
#include <wx/sizer.h>
#include <wx/spinctrl.h>
#include <wx/statbox.h>
#include <wx/stattext.h>
#include <wx/textctrl.h>

#include <cmath>
#include <utility>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/pipeline/full_pipeline.h"

namespace lookboth::studio_app {
namespace {

const wxColour kProblemText(200, 30, 30);
const wxColour kProblemField(255, 220, 220);

void showProblems(wxStaticText* text, const std::vector<std::string>& problems) {
  std::string joined;
  for (const auto& p : problems) joined += (joined.empty() ? "" : "\n") + p;
  text->SetLabel(wxString::FromUTF8(joined));
  text->Wrap(250);
}

void markField(wxWindow* field, bool bad) {
  field->SetBackgroundColour(bad ? kProblemField : wxNullColour);
  field->Refresh();
}

}  // namespace

SetupPanel::SetupPanel(wxWindow* parent, Callbacks callbacks)
    : wxPanel(parent), callbacks_(std::move(callbacks)) {
  auto* sizer = new wxBoxSizer(wxVERTICAL);
  buildDatasetBox(sizer);
  buildMarkerBox(sizer);
  buildTrajectoryBox(sizer);
  buildLossBox(sizer);
  SetSizer(sizer);
  for (wxStaticText* m : {marker_msg_, trajectory_msg_, loss_msg_, validation_})
    m->SetForegroundColour(kProblemText);
  auto changed = [this](wxCommandEvent& e) {
    if (callbacks_.changed) callbacks_.changed();
    e.Skip();
  };
  for (wxTextCtrl* t : {marker_size_, huber_, cauchy_, gate_}) t->Bind(wxEVT_TEXT, changed);
  dictionary_->Bind(wxEVT_CHOICE, changed);
  marker_id_->Bind(wxEVT_SPINCTRL, changed);
  trajectory_mode_->Bind(wxEVT_RADIOBOX, changed);
  trajectory_label_->Bind(wxEVT_CHOICE, changed);
}

void SetupPanel::buildDatasetBox(wxSizer* sizer) {
  auto* box = new wxStaticBoxSizer(wxVERTICAL, this, "Dataset");
  dataset_text_ = new wxStaticText(box->GetStaticBox(), wxID_ANY, "(none)");
  box->Add(dataset_text_, 0, wxALL | wxEXPAND, 4);
  validation_ = new wxStaticText(box->GetStaticBox(), wxID_ANY, "");
  box->Add(validation_, 0, wxLEFT | wxRIGHT | wxEXPAND, 4);
  sizer->Add(box, 0, wxALL | wxEXPAND, 6);
}

void SetupPanel::buildMarkerBox(wxSizer* sizer) {
  auto* box = new wxStaticBoxSizer(wxVERTICAL, this, "Marker");
  auto* grid = new wxFlexGridSizer(2, 4, 6);
  grid->AddGrowableCol(1);
  wxWindow* mb = box->GetStaticBox();
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
  box->Add(grid, 0, wxALL | wxEXPAND, 4);
  marker_msg_ = new wxStaticText(mb, wxID_ANY, "");
  box->Add(marker_msg_, 0, wxLEFT | wxRIGHT | wxEXPAND, 4);
  marker_apply_->SetToolTip(
      "Write this marker into the dataset's manifest (detection then looks for it)");
  marker_apply_->Disable();
  marker_apply_->Bind(wxEVT_BUTTON, [this](wxCommandEvent&) {
    if (callbacks_.apply_marker) callbacks_.apply_marker();
  });
  sizer->Add(box, 0, wxLEFT | wxRIGHT | wxEXPAND, 6);
}

void SetupPanel::buildTrajectoryBox(wxSizer* sizer) {
  auto* box = new wxStaticBoxSizer(wxVERTICAL, this, "Trajectory");
  // Short enough for the settings panel; the tooltip says more.
  const wxString modes[] = {"up to scale (visual)", "metric (scale 1)"};
  trajectory_mode_ = new wxRadioBox(box->GetStaticBox(), wxID_ANY, "Source", wxDefaultPosition,
                                    wxDefaultSize, 2, modes, 1);
  trajectory_mode_->SetToolTip(
      "Up to scale: visual odometry or a monocular SLAM trajectory, whose scale the "
      "registration estimates. Metric: wheels + IMU, LiDAR or motion capture, scale 1.");
  box->Add(trajectory_mode_, 0, wxALL | wxEXPAND, 4);
  auto* label_row = new wxBoxSizer(wxHORIZONTAL);
  label_row->Add(new wxStaticText(box->GetStaticBox(), wxID_ANY, "Trajectory"), 0,
                 wxALIGN_CENTER_VERTICAL | wxRIGHT, 6);
  trajectory_label_ = new wxChoice(box->GetStaticBox(), wxID_ANY);
  label_row->Add(trajectory_label_, 1, wxEXPAND);
  box->Add(label_row, 0, wxALL | wxEXPAND, 4);
  trajectory_msg_ = new wxStaticText(box->GetStaticBox(), wxID_ANY, "");
  box->Add(trajectory_msg_, 0, wxLEFT | wxRIGHT | wxEXPAND, 4);
  sizer->Add(box, 0, wxALL | wxEXPAND, 6);
}

void SetupPanel::buildLossBox(wxSizer* sizer) {
  auto* box = new wxStaticBoxSizer(wxVERTICAL, this, "Robust losses");
  auto* grid = new wxFlexGridSizer(2, 4, 6);
  grid->AddGrowableCol(1);
  wxWindow* lb = box->GetStaticBox();
  grid->Add(new wxStaticText(lb, wxID_ANY, "Huber, looking down [sigma]"), 0,
            wxALIGN_CENTER_VERTICAL);
  huber_ = new wxTextCtrl(lb, wxID_ANY, "3.0");
  grid->Add(huber_, 1, wxEXPAND);
  grid->Add(new wxStaticText(lb, wxID_ANY, "Cauchy, looking up [px]"), 0, wxALIGN_CENTER_VERTICAL);
  cauchy_ = new wxTextCtrl(lb, wxID_ANY, "2.0");
  grid->Add(cauchy_, 1, wxEXPAND);
  grid->Add(new wxStaticText(lb, wxID_ANY, "Blob gate [px]"), 0, wxALIGN_CENTER_VERTICAL);
  gate_ = new wxTextCtrl(lb, wxID_ANY, "25");
  grid->Add(gate_, 1, wxEXPAND);
  box->Add(grid, 0, wxALL | wxEXPAND, 4);
  loss_msg_ = new wxStaticText(lb, wxID_ANY, "");
  box->Add(loss_msg_, 0, wxLEFT | wxRIGHT | wxEXPAND, 4);
  sizer->Add(box, 0, wxLEFT | wxRIGHT | wxEXPAND, 6);
}

void SetupPanel::showDataset(const studio::DatasetIndex& index, bool new_dataset,
                             const std::string& trajectory) {
  const Manifest& m = index.manifest();
  const auto& counts = index.recordCounts();
  auto count = [&](const char* kind) {
    const auto it = counts.find(kind);
    return it == counts.end() ? std::int64_t{0} : it->second;
  };
  const int cameras = static_cast<int>(index.cameraSummaries().size());
  dataset_text_->SetLabel(wxString::FromUTF8(
      m.name + "\n" + std::to_string(cameras) + " environment cameras\n" +
      std::to_string(count("image")) + " images, " + std::to_string(count("marker")) +
      " marker detections,\n" + std::to_string(count("blobs")) + " blob frames, " +
      std::to_string(index.trajectories().size()) + " trajectories"));
  dataset_text_->Wrap(270);
  if (!new_dataset) return;
  dictionary_->SetStringSelection(m.marker.dictionary);
  marker_id_->SetValue(m.marker.id);
  marker_size_->ChangeValue(formatDouble(m.marker.size_m));
  selectTrajectory(index, trajectory);
}

void SetupPanel::selectTrajectory(const studio::DatasetIndex& index,
                                  const std::string& trajectory) {
  const Manifest& m = index.manifest();
  DatasetContents contents;
  contents.trajectories = m.trajectories;
  contents.fisheye_frames = static_cast<std::int64_t>(index.fisheyeFrames().size());
  // The command line's choice (chooseTrajectory), unless the startup names a mode.
  TrajectoryChoice choice;
  try {
    choice = chooseTrajectory(index.path(), contents);
    callbacks_.log("  trajectory: " + wxString::FromUTF8(choice.reason));
  } catch (const Error& e) {
    callbacks_.log("  trajectory: " + wxString::FromUTF8(e.what()));
  }
  // The dataset's trajectories (never its ground truth), and the visual
  // odometry's when it is chosen before it exists.
  trajectory_label_->Clear();
  for (const auto& info : m.trajectories)
    if (info.label != "ground_truth") trajectory_label_->Append(info.label);
  if (!choice.label.empty() && !m.findTrajectory(choice.label))
    trajectory_label_->Append(wxString::FromUTF8(choice.label));
  if (trajectory == "visual") choice.mode = TrajectoryMode::kVisual;
  if (trajectory == "metric") {
    choice.mode = TrajectoryMode::kMetric;
    const TrajectoryInfo* chosen = m.findTrajectory(choice.label);
    if (!chosen || !chosen->metric) choice.label = "odometry";
  }
  if (!trajectory_label_->SetStringSelection(wxString::FromUTF8(choice.label)) &&
      trajectory_label_->GetCount() > 0)
    trajectory_label_->SetSelection(0);
  trajectory_mode_->SetSelection(choice.mode == TrajectoryMode::kMetric ? 1 : 0);
}

std::vector<std::string> SetupPanel::checkLosses() {
  // Read and checked by the stages' own options, as `lookboth register`
  // reads the same settings over default.yaml.
  std::string error;
  try {
    const RegistrationController check(loadRegistrationConfig(std::nullopt, settingsYaml()));
  } catch (const Error& e) {
    error = e.what();
  }
  const std::pair<wxTextCtrl*, const char*> fields[] = {
      {huber_, "look_down.huber'"}, {cauchy_, "look_up.cauchy_px'"}, {gate_, "gate_px'"}};
  for (const auto& [field, key] : fields) markField(field, error.find(key) != std::string::npos);
  if (error.empty()) return {};
  return {error};
}

bool SetupPanel::validate(const studio::DatasetIndex* index, bool idle) {
  // Each message goes next to its field; the steps wait until all are clear.
  std::vector<std::string> marker_problems, trajectory_problems, dataset_problems;
  const MarkerSpec marker = this->marker();
  if (const std::string m = marker.check(); !m.empty()) marker_problems.push_back(m);
  markField(marker_size_, marker.size_m <= 0);
  const std::vector<std::string> loss_problems = checkLosses();
  const bool metric = trajectoryMode() == TrajectoryMode::kMetric;
  const std::string label = trajectoryLabel();
  if (trajectory_label_->GetCount() == 0)
    trajectory_problems.push_back("The dataset has no trajectory and no fisheye frames.");
  if (index) {
    const Manifest& m = index->manifest();
    const TrajectoryInfo* info = m.findTrajectory(label);
    if (metric && info && !info->metric)
      trajectory_problems.push_back("'" + label + "' is known up to scale: choose visual.");
    if (!metric && label == "vo" && index->fisheyeFrames().empty() && !index->trajectory("vo"))
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
    for (const auto& summary : index->cameraSummaries())
      if (!summary.has_calibration)
        uncalibrated += (uncalibrated.empty() ? "" : ", ") + summary.label;
    if (!uncalibrated.empty())
      dataset_problems.push_back("No camera model for " + uncalibrated +
                                 ": their frames cannot be detected (add the calibration to "
                                 "the dataset's manifest, doc/formats.md).");
  }
  showProblems(marker_msg_, marker_problems);
  showProblems(trajectory_msg_, trajectory_problems);
  showProblems(loss_msg_, loss_problems);
  showProblems(validation_, dataset_problems);
  // The marker message about the dataset's marker and the cameras' notes are warnings only.
  const bool marker_blocking = !marker.check().empty();
  marker_apply_->Enable(index && !marker_blocking && !marker_problems.empty() && idle);
  Layout();
  return !marker_blocking && trajectory_problems.empty() && loss_problems.empty();
}

MarkerSpec SetupPanel::marker() const {
  MarkerSpec marker;
  marker.dictionary = dictionary_->GetStringSelection().ToStdString();
  marker.id = marker_id_->GetValue();
  marker.size_m = parseDouble(marker_size_->GetValue().ToStdString()).value_or(-1);
  return marker;
}

TrajectoryMode SetupPanel::trajectoryMode() const {
  return trajectory_mode_->GetSelection() == 1 ? TrajectoryMode::kMetric : TrajectoryMode::kVisual;
}

std::string SetupPanel::trajectoryLabel() const {
  return trajectory_label_->GetStringSelection().ToStdString();
}

std::string SetupPanel::settingsYaml() const {
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

}  // namespace lookboth::studio_app
