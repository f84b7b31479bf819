// The dataset manifest: everything about a recording that is not a
// time-stamped measurement. A dataset `<dir>/<name>.rawlog` has its manifest
// in `<dir>/<name>.yaml` (format in doc/formats.md).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/time.h"

namespace lookboth {

/// The fiducial on the robot.
struct MarkerSpec {
  std::string dictionary = "DICT_4X4_50";  ///< OpenCV predefined dictionary name.
  int id = 0;                              ///< Marker id within the dictionary.
  double size_m = 0.2;                     ///< Side of the black square [m].
  /// Empty when valid; else names the field ("'dictionary': unknown 'DICT_9X9'...").
  std::string check() const;
};

/// Names accepted for MarkerSpec::dictionary, with their number of markers.
const std::map<std::string, int>& knownMarkerDictionaries();

enum class SensorRole { kFisheye, kEnvCamera };
const char* sensorRoleName(SensorRole role);

/// A camera of the recording with its calibration.
struct CameraSensor {
  std::string label;
  SensorRole role = SensorRole::kEnvCamera;
  std::optional<Camera> camera;  ///< Calibration; may be absent (then detection is impossible).
};

/// A trajectory held in the dataset as PoseSample records with this label.
struct TrajectoryInfo {
  std::string label;        ///< e.g. "odometry", "vo", "ground_truth".
  bool metric = true;       ///< false: known up to an unknown scale (monocular VO).
  std::string description;  ///< Free text ("wheel+IMU", "lookboth odometry", ...).
};

/// Times [begin, end] (both included) on the fisheye's clock [ns].
struct TimeSpan {
  TimeNs begin = 0, end = 0;
  bool contains(TimeNs t) const { return t >= begin && t <= end; }
};

/// What a simulation knows and a real recording usually does not.
struct GroundTruth {
  std::map<std::string, Rigid3d> world_from_camera;  ///< By environment camera label.
  std::optional<Rigid3d> fisheye_from_marker;
  std::map<std::string, TimeNs> clock_offset;  ///< node clock - robot clock, by sensor label [ns].
  /// By environment camera label: the fisheye's frames in which the world
  /// (a beam, a duct, a tray) stands between the fisheye and the camera's
  /// optical centre, as spans of their stamps, sorted. The housing's blob is
  /// then missing (or only its dome's rim shows), so a blob detector's
  /// recall is scored on the other frames.
  std::map<std::string, std::vector<TimeSpan>> hidden_from_fisheye;
  bool empty() const {
    return world_from_camera.empty() && !fisheye_from_marker && clock_offset.empty() &&
           hidden_from_fisheye.empty();
  }
  /// Whether `camera` is hidden from the fisheye in its frame stamped `t`.
  bool hiddenFromFisheye(const std::string& camera, TimeNs t) const;
};

struct Manifest {
  std::string name;  ///< Dataset name (the rawlog's stem or the folder's name).
  MarkerSpec marker;
  std::vector<CameraSensor> cameras;  ///< The fisheye first (if any), then environment cameras.
  std::vector<TrajectoryInfo> trajectories;
  GroundTruth ground_truth;
  /// Number of entries the rawlog writer wrote (lets a reader tell a
  /// truncated rawlog from a complete one); -1 when unknown.
  std::int64_t rawlog_entries = -1;

  /// The camera with that label, or nullptr.
  const CameraSensor* findCamera(const std::string& label) const;
  /// The (first) camera with role fisheye, or nullptr.
  const CameraSensor* fisheye() const;
  const TrajectoryInfo* findTrajectory(const std::string& label) const;
  /// Empty when consistent; else a message naming the field (duplicate
  /// labels, a bad marker, ground truth for an unknown camera...).
  std::string check() const;
};

/// Reads a manifest; errors name the file and the field.
Manifest loadManifest(const std::filesystem::path& path);
/// YAML text of a manifest (cameras inline in lookboth's camera YAML).
std::string manifestToYaml(const Manifest& manifest);
/// Writes atomically.
void saveManifest(const Manifest& manifest, const std::filesystem::path& path);
/// Parses YAML text; `source` names it in errors.
Manifest manifestFromYaml(const std::string& yaml, const std::string& source);

}  // namespace lookboth
