// Loading and saving camera calibrations in the formats people already have.
//
// Every loader throws lookboth::Error whose message names the file and the
// field (and the line where the format has lines) when the file is missing,
// malformed, or inconsistent (wrong number of coefficients, non-positive focal
// length, unknown model...). No loader returns a silently wrong model.
#pragma once

#include <filesystem>
#include <map>
#include <string>

#include "lookboth/cameras/camera.h"

namespace mrpt::img {
class TCamera;
}

namespace lookboth {

/// Calibration file formats lookboth reads.
enum class CameraFileFormat {
  kAuto,           ///< Detect from the contents (see `detectCameraFileFormat`).
  kLookboth,       ///< lookboth's own YAML (doc/formats.md): model, width, height, named params.
  kRosCameraInfo,  ///< ROS camera_info YAML (camera_calibration_parsers): plumb_bob,
                   ///< rational_polynomial, equidistant.
  kKalibr,         ///< Kalibr camchain / camera YAML (cam0, cam1...): pinhole-radtan,
                   ///< pinhole-equi, pinhole-fov, pinhole-none, ds, eucm, omni[-radtan].
  kOCamCalib,      ///< OCamCalib calib_results.txt (Scaramuzza).
  kOpenCV,         ///< OpenCV FileStorage YAML or XML (camera_matrix, distortion_coefficients).
  kCamOdoCal,      ///< CamOdoCal YAML (VINS-Mono, VINS-Fusion): model_type MEI, PINHOLE,
                   ///< KANNALA_BRANDT.
};

std::string cameraFileFormatName(CameraFileFormat format);

/// Guesses the format from the file contents; throws lookboth::Error naming
/// the file when it is none of the known ones.
CameraFileFormat detectCameraFileFormat(const std::filesystem::path& path);

/// Loads one camera. For files holding several cameras (Kalibr camchain),
/// `camera_name` picks one ("cam1"); empty means the file must hold exactly one
/// camera, or the first one ("cam0") for Kalibr.
Camera loadCamera(const std::filesystem::path& path,
                  CameraFileFormat format = CameraFileFormat::kAuto,
                  const std::string& camera_name = "");

/// Loads every camera of a Kalibr camchain, keyed by "cam0", "cam1", ...
std::map<std::string, Camera> loadKalibrCamchain(const std::filesystem::path& path);

/// Writes lookboth's own YAML (atomically: temporary name, then rename).
void saveCamera(const Camera& camera, const std::filesystem::path& path);
/// lookboth's own YAML as a string (what `saveCamera` writes).
std::string cameraToYaml(const Camera& camera);
/// Parses lookboth's own YAML from a string; `source` names it in errors.
Camera cameraFromYaml(const std::string& yaml, const std::string& source);

/// MRPT's TCamera can hold pinhole, radtan (5 coefficients), rational
/// polynomial (8) and Kannala-Brandt models. Throws lookboth::Error for the
/// others (Scaramuzza, double sphere), saying so.
mrpt::img::TCamera toMrptCamera(const Camera& camera);
/// From MRPT's TCamera (none -> pinhole, plumb_bob -> radtan or rational
/// polynomial when k4..k6 are non-zero, kannala_brandt -> kannala_brandt).
Camera fromMrptCamera(const mrpt::img::TCamera& camera);

}  // namespace lookboth
