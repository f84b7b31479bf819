// `lookboth camera info|check|convert`: inspect, verify and convert camera
// calibration files.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "commands.h"
#include "lookboth/cameras/camera_io.h"
#include "lookboth/cameras/self_check.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/paths.h"
#include "lookboth/core/text.h"

namespace lookboth::app {
namespace {

const std::map<std::string, CameraFileFormat> kFormats = {
    {"auto", CameraFileFormat::kAuto},           {"lookboth", CameraFileFormat::kLookboth},
    {"ros", CameraFileFormat::kRosCameraInfo},   {"kalibr", CameraFileFormat::kKalibr},
    {"ocamcalib", CameraFileFormat::kOCamCalib}, {"opencv", CameraFileFormat::kOpenCV},
    {"camodocal", CameraFileFormat::kCamOdoCal}};

struct NamedCamera {
  std::string label;  // "file" or "file:cam1"
  Camera camera;
};

// Every camera in a file: all cameras of a Kalibr camchain, else the one camera.
std::vector<NamedCamera> loadAllCameras(const std::filesystem::path& path,
                                        CameraFileFormat format) {
  std::vector<NamedCamera> cameras;
  const CameraFileFormat detected =
      format == CameraFileFormat::kAuto ? detectCameraFileFormat(path) : format;
  const std::string label = path.filename().string();
  if (detected == CameraFileFormat::kKalibr) {
    for (auto& [name, camera] : loadKalibrCamchain(path))
      cameras.push_back({label + ":" + name, camera});
  } else {
    cameras.push_back({label, loadCamera(path, detected)});
  }
  return cameras;
}

std::vector<std::filesystem::path> defaultCameraFiles() {
  const std::filesystem::path dir = shareDirectory() / "cameras";
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.is_regular_file()) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string fixed(double v, int decimals) { return formatFixed(v, decimals); }

std::string scientific(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.1e", v);
  return buffer;
}

int runInfo(const std::string& file, const std::string& format_name,
            const std::string& camera_name) {
  const Camera camera = loadCamera(file, kFormats.at(format_name), camera_name);
  std::cout << "file:       " << file << "\n"
            << "format:     " << cameraFileFormatName(detectCameraFileFormat(file)) << "\n"
            << "model:      " << camera.modelName() << "\n"
            << "size:       " << camera.width() << " x " << camera.height() << " px\n"
            << "fov:        " << fixed(camera.fieldOfView() * 180.0 / M_PI, 1)
            << " deg across the image\n"
            << "valid up to " << fixed(camera.maxIncidenceAngle() * 180.0 / M_PI, 1)
            << " deg from the optical axis\n"
            << "parameters:\n";
  const auto names = camera.paramNames();
  for (size_t i = 0; i < names.size(); ++i) {
    std::cout << "  " << names[i] << ": " << formatDouble(camera.params()[i]) << "\n";
  }
  return 0;
}

int runConvert(const std::string& file, const std::string& format_name,
               const std::string& camera_name, const std::string& out, bool overwrite) {
  checkOutputPath(out, {file}, overwrite);
  const Camera camera = loadCamera(file, kFormats.at(format_name), camera_name);
  saveCamera(camera, out);
  std::cout << "wrote " << out << " (" << camera.description() << ")\n";
  return 0;
}

int runCheck(std::vector<std::string> files, const std::string& format_name, int samples) {
  std::vector<std::filesystem::path> paths(files.begin(), files.end());
  if (paths.empty()) paths = defaultCameraFiles();
  CameraSelfCheckOptions options;
  options.num_rays = options.num_pixels = samples;
  if (const std::string why = options.check(); !why.empty()) throw Error(why);

  std::printf("%-34s %-20s %-11s %8s %8s %11s %11s  %s\n", "camera", "model", "size", "fov[deg]",
              "max[deg]", "ray err[rad]", "px err[px]", "status");
  int failures = 0;
  int checked = 0;
  for (const auto& path : paths) {
    for (const NamedCamera& named : loadAllCameras(path, kFormats.at(format_name))) {
      const CameraSelfCheck check = selfCheckCamera(named.camera, options);
      ++checked;
      const std::string size =
          std::to_string(named.camera.width()) + "x" + std::to_string(named.camera.height());
      std::printf(
          "%-34s %-20s %-11s %8s %8s %11s %11s  %s\n", named.label.c_str(),
          named.camera.modelName().c_str(), size.c_str(), fixed(check.field_of_view_deg, 1).c_str(),
          fixed(check.max_incidence_deg, 1).c_str(), scientific(check.max_ray_error_rad).c_str(),
          scientific(check.max_pixel_error_px).c_str(), check.passed ? "ok" : "FAILED");
      if (!check.passed) {
        ++failures;
        std::printf(
            "    rays that did not project: %d of %d; pixels without a ray: %d; rejects rays past "
            "the FoV: %s\n",
            check.rays_failed, check.rays_tested, check.pixels_without_ray,
            check.rejects_beyond_fov ? "yes" : "no");
      }
    }
  }
  std::printf("%d camera(s) checked with %d rays and %d pixels each (bounds: %s rad, %s px): %s\n",
              checked, samples, samples, scientific(options.max_ray_error).c_str(),
              scientific(options.max_pixel_error).c_str(),
              failures == 0 ? "all passed" : "FAILURES");
  return failures == 0 ? 0 : 1;
}

}  // namespace

void registerCameraCommands(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  CLI::App* camera =
      app.add_subcommand("camera", "Inspect, check and convert camera calibration files");
  camera->require_subcommand(1);

  struct Options {
    std::string file, format = "auto", camera_name, out;
    bool overwrite = false;
    std::vector<std::string> files;
    int samples = 5000;
  };
  auto options = std::make_shared<Options>();
  const auto format_check =
      CLI::IsMember({"auto", "lookboth", "ros", "kalibr", "ocamcalib", "opencv"});

  CLI::App* info = camera->add_subcommand("info", "Load a calibration file and print the model");
  info->add_option("file", options->file,
                   "Calibration file (lookboth YAML, ROS camera_info, Kalibr, "
                   "OCamCalib calib_results.txt, OpenCV YAML/XML)")
      ->required()
      ->check(CLI::ExistingFile);
  info->add_option("--format", options->format, "File format (default: detected)")
      ->check(format_check);
  info->add_option("--camera", options->camera_name, "Camera in a multi-camera file (e.g. cam1)");
  info->callback([options, set_body] {
    set_body([options] { return runInfo(options->file, options->format, options->camera_name); });
  });

  CLI::App* convert =
      camera->add_subcommand("convert", "Convert a calibration file to lookboth's YAML");
  convert->add_option("file", options->file, "Calibration file")
      ->required()
      ->check(CLI::ExistingFile);
  convert->add_option("--out", options->out, "Output lookboth camera YAML")->required();
  convert->add_flag("--overwrite", options->overwrite, "Replace an existing --out");
  convert->add_option("--format", options->format, "Input format (default: detected)")
      ->check(format_check);
  convert->add_option("--camera", options->camera_name,
                      "Camera in a multi-camera file (e.g. cam1)");
  convert->callback([options, set_body] {
    set_body([options] {
      return runConvert(options->file, options->format, options->camera_name, options->out,
                        options->overwrite);
    });
  });

  CLI::App* check = camera->add_subcommand(
      "check",
      "Self-check camera models: project/unproject round trips over the whole field of view");
  check
      ->add_option("files", options->files,
                   "Calibration files (default: every sample under share/lookboth/cameras)")
      ->check(CLI::ExistingFile);
  check->add_option("--format", options->format, "File format (default: detected)")
      ->check(format_check);
  check->add_option("--samples", options->samples, "Random rays and pixels per camera")
      ->check(CLI::PositiveNumber);
  check->callback([options, set_body] {
    set_body([options] { return runCheck(options->files, options->format, options->samples); });
  });
}

}  // namespace lookboth::app
