#include "lookboth/studio/dataset_edit.h"

#include <algorithm>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/dataset/augment.h"
#include "lookboth/dataset/dataset_io.h"

namespace lookboth::studio {

Camera setCameraCalibration(const std::filesystem::path& dataset, const std::string& label,
                            const std::filesystem::path& calibration_file,
                            const ProgressReporter& progress, const std::string& camera_name) {
  // Load first: a file that is not a calibration changes nothing.
  const Camera camera = loadCamera(calibration_file, CameraFileFormat::kAuto, camera_name);
  DatasetReadOptions read_options;
  read_options.check_images = false;
  Manifest manifest = DatasetReader::open(dataset, read_options)->manifest();
  const auto it = std::find_if(manifest.cameras.begin(), manifest.cameras.end(),
                               [&](const CameraSensor& c) { return c.label == label; });
  if (it == manifest.cameras.end()) {
    std::string known;
    for (const CameraSensor& c : manifest.cameras) known += (known.empty() ? "" : ", ") + c.label;
    throw Error(ErrorContext{dataset.string(), 0, "", label},
                "no camera '" + label + "' in this dataset (cameras: " + known + ")");
  }
  it->camera = camera;
  AugmentOptions options;
  options.input = dataset;
  options.manifest = manifest;
  augmentDataset(options, {}, progress);
  return camera;
}

void setMarker(const std::filesystem::path& dataset, const MarkerSpec& marker,
               const ProgressReporter& progress) {
  if (const std::string why = marker.check(); !why.empty())
    throw Error(ErrorContext{dataset.string(), 0, "marker", ""}, why);
  DatasetReadOptions read_options;
  read_options.check_images = false;
  Manifest manifest = DatasetReader::open(dataset, read_options)->manifest();
  manifest.marker = marker;
  AugmentOptions options;
  options.input = dataset;
  options.manifest = manifest;
  augmentDataset(options, {}, progress);
}

}  // namespace lookboth::studio
