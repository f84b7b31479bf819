// Edits of a dataset the desktop app offers (the technician's fixes), done
// through augmentDataset: a complete new dataset is written and swapped in,
// never a half-written one.
#pragma once

#include <filesystem>
#include <string>

#include "lookboth/cameras/camera.h"
#include "lookboth/core/progress.h"
#include "lookboth/dataset/manifest.h"

namespace lookboth::studio {

/// Sets the calibration of the camera `label` (fisheye or environment camera)
/// in the dataset's manifest to the one in `calibration_file` (any format
/// `loadCamera` reads; for a Kalibr camchain, `camera_name` picks one) and
/// returns it. Records are kept as they are: detections made with another
/// model stay until detection runs again. Throws lookboth::Error naming the
/// file when it cannot be loaded, naming the dataset and the label when the
/// dataset has no such camera (the dataset is then untouched); StopRequested
/// when stopped (the dataset is then as it was).
Camera setCameraCalibration(const std::filesystem::path& dataset, const std::string& label,
                            const std::filesystem::path& calibration_file,
                            const ProgressReporter& progress, const std::string& camera_name = "");

/// Sets the dataset's marker (dictionary, id, size). Records are kept: marker
/// detections made for another marker stay until detection runs again. Throws
/// lookboth::Error naming the field when `marker` is not valid (the dataset is
/// then untouched), StopRequested when stopped.
void setMarker(const std::filesystem::path& dataset, const MarkerSpec& marker,
               const ProgressReporter& progress);

}  // namespace lookboth::studio
