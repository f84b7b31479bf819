#include "camera_table.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "lookboth/core/text.h"

namespace lookboth::studio_app {

namespace {
constexpr int kColumns = 9;
/// The columns as shown: the check's verdict next to the status, where it is seen.
constexpr int kShown[kColumns] = {0, 1, 2, 8, 3, 4, 5, 6, 7};

std::string formatPosition(const Eigen::Vector3d& t) {
  return formatFixed(t.x(), 3) + ", " + formatFixed(t.y(), 3) + ", " + formatFixed(t.z(), 3);
}
}  // namespace

// One row as text, plus the numbers it sorts by.
struct CameraTable::Row {
  std::string label;
  std::string cells[kColumns];
  double sort_keys[kColumns] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  bool warn = false;
  bool moved = false;
};

CameraTable::CameraTable(wxWindow* parent, std::function<void(const std::string&)> on_select)
    : wxListCtrl(parent, wxID_ANY, wxDefaultPosition, wxDefaultSize,
                 wxLC_REPORT | wxLC_SINGLE_SEL | wxLC_HRULES),
      on_select_(std::move(on_select)) {
  const char* columns[kColumns] = {"Camera",        "Detections",      "Status",
                                   "Residual [mm]", "Sigma pos. [mm]", "Reprojection [px]",
                                   "Position [m]",  "Warnings",        "Since the record"};
  const int widths[kColumns] = {75, 85, 95, 105, 120, 125, 175, 320, 195};
  for (const int i : kShown) AppendColumn(columns[i], wxLIST_FORMAT_LEFT, widths[i]);
  Bind(wxEVT_LIST_ITEM_SELECTED, [this](wxListEvent& e) {
    const long row = e.GetIndex();
    if (row >= 0 && static_cast<size_t>(row) < labels_.size() && on_select_)
      on_select_(labels_[static_cast<size_t>(row)]);
  });
  Bind(wxEVT_LIST_COL_CLICK, [this](wxListEvent& e) {
    if (e.GetColumn() == sort_column_) {
      sort_ascending_ = !sort_ascending_;
    } else {
      sort_column_ = e.GetColumn();
      sort_ascending_ = true;
    }
    refresh();
  });
}

void CameraTable::show(std::shared_ptr<const studio::DatasetIndex> index,
                       std::shared_ptr<const Registration> registration) {
  index_ = std::move(index);
  registration_ = std::move(registration);
  refresh();
}

void CameraTable::showCheck(std::shared_ptr<const FacilityCheck> check) {
  check_ = std::move(check);
  refresh();
}

void CameraTable::setSelected(const std::string& label) {
  selected_ = label;
  for (size_t i = 0; i < labels_.size(); ++i) {
    const bool on = labels_[i] == label;
    SetItemState(static_cast<long>(i), on ? wxLIST_STATE_SELECTED : 0, wxLIST_STATE_SELECTED);
    if (on) EnsureVisible(static_cast<long>(i));
  }
}

CameraTable::Row CameraTable::rowOf(const studio::CameraSummary& summary) const {
  Row row;
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
  if (!reg) {
    // Before a registration: where the truth puts it, for a simulated dataset.
    const auto& truth = index_->manifest().ground_truth.world_from_camera;
    if (const auto it = truth.find(summary.label); it != truth.end())
      row.cells[6] = formatPosition(it->second.translation) + " (truth)";
    row.warn = !row.cells[7].empty();
    return row;
  }
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
    const double sigma = std::sqrt(std::max(0.0, reg->covariance->topLeftCorner<3, 3>().trace()));
    row.cells[4] = formatFixed(1000 * sigma, 1);
    row.sort_keys[4] = sigma;
  }
  if (reg->reprojection && reg->reprojection->blobs > 0) {
    row.cells[5] = formatFixed(reg->reprojection->rms_px_before, 2) + " -> " +
                   formatFixed(reg->reprojection->rms_px_after, 2);
    row.sort_keys[5] = reg->reprojection->rms_px_after;
  }
  if (reg->status != CameraStatus::kUnregistered)
    row.cells[6] = formatPosition(reg->world_from_camera.translation);
  std::string notes = reg->reason;
  for (const auto& w : reg->warnings) notes += (notes.empty() ? "" : "; ") + w;
  row.cells[7] = notes;
  row.warn = reg->status != CameraStatus::kRegistered || !reg->warnings.empty();
  return row;
}

namespace {

/// "moved 51 mm 0.18 deg", "unchanged 6 mm 0.14 deg", "not seen", "new".
std::string sinceRecord(const CameraCheck& c) {
  if (c.verdict != CameraVerdict::kMoved && c.verdict != CameraVerdict::kUnchanged)
    return cameraVerdictName(c.verdict);
  return std::string(cameraVerdictName(c.verdict)) + " " + formatFixed(c.moved_m.norm() * 1000, 0) +
         " mm " + formatFixed(c.rotated_deg, 2) + " deg";
}

}  // namespace

void CameraTable::refresh() {
  DeleteAllItems();
  labels_.clear();
  if (!index_) return;
  std::vector<Row> rows;
  for (const auto& summary : index_->cameraSummaries()) {
    rows.push_back(rowOf(summary));
    if (!check_) continue;
    for (const CameraCheck& c : check_->cameras) {
      if (c.label != summary.label) continue;
      rows.back().cells[8] = sinceRecord(c);
      rows.back().sort_keys[8] = c.position_chi2;
      rows.back().moved = c.verdict == CameraVerdict::kMoved;
    }
  }
  const int column = kShown[std::clamp(sort_column_, 0, kColumns - 1)];
  const bool numeric = (column >= 1 && column <= 5) || column == 8;
  std::stable_sort(rows.begin(), rows.end(), [&](const Row& a, const Row& b) {
    const bool less =
        numeric ? a.sort_keys[column] < b.sort_keys[column] : a.cells[column] < b.cells[column];
    const bool greater =
        numeric ? a.sort_keys[column] > b.sort_keys[column] : a.cells[column] > b.cells[column];
    return sort_ascending_ ? less : greater;
  });
  for (const auto& r : rows) {
    const long i = InsertItem(GetItemCount(), wxString::FromUTF8(r.cells[0]));
    for (int c = 1; c < kColumns; ++c) SetItem(i, c, wxString::FromUTF8(r.cells[kShown[c]]));
    if (r.warn) SetItemTextColour(i, wxColour(190, 90, 0));
    if (r.moved) SetItemTextColour(i, wxColour(200, 30, 30));
    labels_.push_back(r.label);
    if (r.label == selected_) SetItemState(i, wxLIST_STATE_SELECTED, wxLIST_STATE_SELECTED);
  }
}

}  // namespace lookboth::studio_app
