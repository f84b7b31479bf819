// The camera table below the views: one row per environment camera (its
// detections, status, residual, uncertainty, reprojection, position and
// warnings), sorted by a click on a column; a click on a row selects the
// camera everywhere.
#pragma once

#include <wx/listctrl.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "lookboth/registration/facility_check.h"
#include "lookboth/registration/registration.h"
#include "lookboth/studio/dataset_index.h"

namespace lookboth::studio_app {

class CameraTable : public wxListCtrl {
 public:
  CameraTable(wxWindow* parent, std::function<void(const std::string&)> on_select);

  /// The dataset's cameras (none when `index` is null), with what the
  /// registration (null: none yet) says of each.
  void show(std::shared_ptr<const studio::DatasetIndex> index,
            std::shared_ptr<const Registration> registration);
  void setSelected(const std::string& label);
  /// The registration checked against the one on record (null: no check):
  /// each camera's verdict in the last column, moved ones in red.
  void showCheck(std::shared_ptr<const FacilityCheck> check);

 private:
  struct Row;
  Row rowOf(const studio::CameraSummary& summary) const;
  void refresh();

  std::function<void(const std::string&)> on_select_;
  std::shared_ptr<const studio::DatasetIndex> index_;
  std::shared_ptr<const Registration> registration_;
  std::shared_ptr<const FacilityCheck> check_;
  std::vector<std::string> labels_;  ///< The camera of each row, in the order shown.
  std::string selected_;
  int sort_column_ = 0;
  bool sort_ascending_ = true;
};

}  // namespace lookboth::studio_app
