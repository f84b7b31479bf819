// Exports of a registration for the systems that use it (`lookboth export`;
// doc/formats.md, "Exports"): COLMAP's text model, JSON (with a JSON Schema
// in share/lookboth/schema), one OpenCV FileStorage YAML per camera (its
// edge node's), ROS 2 (a URDF, static transforms, camera_info files) and
// MRPT (the trajectory and the cameras as a pose graph with covariances).
//
// Every format carries each exported camera's `world_from_camera` in the
// registration's world frame (registration.yaml says which) and, where the
// format has room for it, its intrinsics and its 6x6 covariance over
// [dt (m); dtheta (rad)] (doc/conventions.md).
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/records.h"
#include "lookboth/registration/registration.h"

namespace lookboth {

enum class ExportFormat { kColmap, kJson, kOpenCv, kRos, kMrpt };

/// "colmap", "json", "opencv", "ros", "mrpt".
const char* exportFormatName(ExportFormat format);
std::optional<ExportFormat> parseExportFormat(const std::string& name);
/// Every format, in the order above.
std::vector<ExportFormat> allExportFormats();
/// "all", or names separated by commas ("colmap,ros"); lookboth::Error
/// naming an unknown one and listing the others.
std::vector<ExportFormat> parseExportFormats(const std::string& text);

struct ExportOptions {
  ExportFormat format = ExportFormat::kJson;
  /// Also export the cameras the registration marked suspect (their status
  /// is written where the format has room for it); unregistered cameras are
  /// never exported.
  bool include_suspect = false;
  /// ROS: the name of the registration's world frame, the URDF's root link
  /// and the parent of every camera's frame.
  std::string world_frame = "site";

  /// Empty when usable; else what is wrong, naming the option.
  std::string check() const;
};

/// What an export reads besides the registration: the registered dataset's
/// calibrations and detections (`readExportSources`).
struct ExportSources {
  /// The cameras' calibrations by label, the fisheye's included.
  std::map<std::string, Camera> intrinsics;
  /// The fisheye's label: MRPT's graph turns its blobs into edges through
  /// its calibration. Empty: no blob edges.
  std::string fisheye;
  /// The detections of the robot's marker: MRPT's graph has an edge from
  /// the trajectory to the camera for each. A camera with none gets one edge
  /// from its registered covariance instead.
  std::vector<MarkerObservation> marker_detections;
};

/// The sources in a dataset's manifest and detections: its calibrations and
/// fisheye, the detections of its robot's marker (the other ids left out).
ExportSources exportSources(const Manifest& manifest,
                            const std::vector<MarkerObservation>& detections);
/// The same read from a dataset: its detections only when `detections` (the
/// MRPT graph's edges; the other formats need the manifest alone, which is
/// read without a pass over the records). lookboth::Error naming the
/// dataset when it cannot be read.
ExportSources readExportSources(const std::filesystem::path& dataset, bool detections);

/// What an export wrote, and what it left out and why (a camera whose model
/// the format cannot express, e.g. a ROS camera_info for a double sphere).
struct ExportResult {
  std::vector<std::filesystem::path> files;
  std::vector<std::string> notes;
  int cameras = 0;
};

/// Writes `registration` in `options.format` into the folder `out` (created
/// if missing; each file written under a temporary name and renamed when
/// complete), with what `sources` holds of the dataset registered. Throws lookboth::Error naming
/// the camera when an exported camera has no calibration, or has a model that a format needing
/// intrinsics (COLMAP) cannot express.
ExportResult exportRegistration(const Registration& registration, const ExportSources& sources,
                                const std::filesystem::path& out, const ExportOptions& options);

/// Several formats at once into the folder `out`, written atomically (under
/// a temporary name, renamed when complete; an existing `out` is replaced,
/// the caller checks --overwrite): one format's files straight into `out`,
/// several one folder each, named after the format. Returns a line per
/// format (cameras, files) and per note, for the command line and the
/// desktop app.
std::vector<std::string> exportRegistrationFormats(const Registration& registration,
                                                   const ExportSources& sources,
                                                   const std::filesystem::path& out,
                                                   const std::vector<ExportFormat>& formats,
                                                   ExportOptions options);

}  // namespace lookboth
