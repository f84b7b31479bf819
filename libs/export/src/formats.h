// The writers behind exportRegistration, one per format (export.h).
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "lookboth/cameras/camera.h"
#include "lookboth/export/export.h"
#include "lookboth/registration/registration.h"

namespace lookboth::export_detail {

/// A camera as the writers see it: its registration and, when the dataset
/// has one, its calibration.
struct ExportedCamera {
  const CameraRegistration* registration = nullptr;
  const Camera* intrinsics = nullptr;
};

struct ExportContext {
  const Registration& registration;
  const ExportSources& sources;
  std::vector<ExportedCamera> cameras;
  std::filesystem::path out;
  ExportOptions options;
  ExportResult* result = nullptr;

  /// Writes `contents` to out/name atomically and records the file.
  void write(const std::filesystem::path& name, const std::string& contents) const;
};

/// The calibration of `camera`, or an Error naming it and `format`.
const Camera& requireIntrinsics(const ExportedCamera& camera, const char* format);

void writeColmap(const ExportContext& context);
void writeJson(const ExportContext& context);
void writeOpenCv(const ExportContext& context);
void writeRos(const ExportContext& context);
void writeMrpt(const ExportContext& context);

}  // namespace lookboth::export_detail
