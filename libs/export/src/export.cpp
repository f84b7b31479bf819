// exportRegistration: the cameras to export, the output folder, the writer.
#include "lookboth/export/export.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <sstream>

#include "formats.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/dataset/dataset_io.h"

namespace lookboth {

const char* exportFormatName(ExportFormat format) {
  switch (format) {
    case ExportFormat::kColmap:
      return "colmap";
    case ExportFormat::kJson:
      return "json";
    case ExportFormat::kOpenCv:
      return "opencv";
    case ExportFormat::kRos:
      return "ros";
    case ExportFormat::kMrpt:
      return "mrpt";
  }
  return "?";
}

std::vector<ExportFormat> allExportFormats() {
  return {ExportFormat::kColmap, ExportFormat::kJson, ExportFormat::kOpenCv, ExportFormat::kRos,
          ExportFormat::kMrpt};
}

std::optional<ExportFormat> parseExportFormat(const std::string& name) {
  for (ExportFormat format : allExportFormats()) {
    if (name == exportFormatName(format)) return format;
  }
  return std::nullopt;
}

std::vector<ExportFormat> parseExportFormats(const std::string& text) {
  if (text == "all") return allExportFormats();
  std::vector<ExportFormat> formats;
  std::istringstream names(text);
  for (std::string name; std::getline(names, name, ',');) {
    const std::optional<ExportFormat> format = parseExportFormat(name);
    if (!format) {
      throw Error("unknown format '" + name +
                  "' (colmap, json, opencv, ros, mrpt, or all; several separated by commas)");
    }
    formats.push_back(*format);
  }
  return formats;
}

std::string ExportOptions::check() const {
  if (world_frame.empty()) return "world_frame: empty (the name of the registration's frame)";
  for (char c : world_frame) {
    const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/';
    if (!ok) {
      return "world_frame: '" + world_frame +
             "' is not a ROS frame name (letters, digits, '_' and '/')";
    }
  }
  return "";
}

ExportSources exportSources(const Manifest& manifest,
                            const std::vector<MarkerObservation>& detections) {
  ExportSources sources;
  for (const CameraSensor& sensor : manifest.cameras) {
    if (sensor.camera) sources.intrinsics.emplace(sensor.label, *sensor.camera);
  }
  if (const CameraSensor* fisheye = manifest.fisheye()) sources.fisheye = fisheye->label;
  for (const MarkerObservation& marker : detections) {
    if (marker.marker_id == manifest.marker.id) sources.marker_detections.push_back(marker);
  }
  return sources;
}

ExportSources readExportSources(const std::filesystem::path& dataset, bool detections) {
  if (!std::filesystem::exists(dataset)) {
    throw Error({dataset.string(), 0, "", ""},
                "the registered dataset is not there; name it with --dataset");
  }
  if (!detections) {
    DatasetReadOptions options;
    options.check_images = false;
    return exportSources(DatasetReader::open(dataset, options)->manifest(), {});
  }
  const MarkerDetections read = readMarkerDetections(dataset);
  return exportSources(read.manifest, read.detections);
}

namespace export_detail {

void ExportContext::write(const std::filesystem::path& name, const std::string& contents) const {
  const std::filesystem::path path = out / name;
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  if (ec) {
    throw Error({path.parent_path().string(), 0, "", ""},
                "cannot create the directory: " + ec.message());
  }
  writeFileAtomically(path, contents);
  result->files.push_back(path);
}

const Camera& requireIntrinsics(const ExportedCamera& camera, const char* format) {
  if (camera.intrinsics == nullptr) {
    throw Error("export " + std::string(format) + ": camera '" + camera.registration->label +
                "' has no calibration in the dataset; the format needs its intrinsics");
  }
  return *camera.intrinsics;
}

}  // namespace export_detail

ExportResult exportRegistration(const Registration& registration, const ExportSources& sources,
                                const std::filesystem::path& out, const ExportOptions& options) {
  if (const std::string why = options.check(); !why.empty()) throw Error("export: " + why);
  ExportResult result;
  export_detail::ExportContext context{registration, sources, {}, out, options, &result};
  const std::map<std::string, Camera>& intrinsics = sources.intrinsics;
  for (const CameraRegistration& camera : registration.cameras) {
    const bool wanted = camera.status == CameraStatus::kRegistered ||
                        (options.include_suspect && camera.status == CameraStatus::kSuspect);
    if (!wanted) continue;
    const auto found = intrinsics.find(camera.label);
    context.cameras.push_back({&camera, found == intrinsics.end() ? nullptr : &found->second});
  }
  if (context.cameras.empty()) {
    throw Error("export: the registration has no " +
                std::string(options.include_suspect ? "registered or suspect" : "registered") +
                " camera to export");
  }
  std::error_code ec;
  std::filesystem::create_directories(out, ec);
  if (ec) throw Error({out.string(), 0, "", ""}, "cannot create the directory: " + ec.message());
  switch (options.format) {
    case ExportFormat::kColmap:
      export_detail::writeColmap(context);
      break;
    case ExportFormat::kJson:
      export_detail::writeJson(context);
      break;
    case ExportFormat::kOpenCv:
      export_detail::writeOpenCv(context);
      break;
    case ExportFormat::kRos:
      export_detail::writeRos(context);
      break;
    case ExportFormat::kMrpt:
      export_detail::writeMrpt(context);
      break;
  }
  result.cameras = static_cast<int>(context.cameras.size());
  return result;
}

std::vector<std::string> exportRegistrationFormats(const Registration& registration,
                                                   const ExportSources& sources,
                                                   const std::filesystem::path& out,
                                                   const std::vector<ExportFormat>& formats,
                                                   ExportOptions options) {
  std::vector<std::string> lines;
  writeDirectoryAtomically(out, [&](const std::filesystem::path& folder) {
    for (ExportFormat format : formats) {
      options.format = format;
      const std::filesystem::path where =
          formats.size() == 1 ? folder : folder / exportFormatName(format);
      const ExportResult result = exportRegistration(registration, sources, where, options);
      lines.push_back(std::string(exportFormatName(format)) + ": " +
                      std::to_string(result.cameras) + " cameras, " +
                      std::to_string(result.files.size()) + " files");
      for (const std::string& note : result.notes) lines.push_back("  note: " + note);
    }
  });
  return lines;
}

}  // namespace lookboth
