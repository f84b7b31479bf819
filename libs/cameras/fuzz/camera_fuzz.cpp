// Fuzz target "camera": the bytes as a calibration file, read by loadCamera
// in every format (detected, then each one forced) and by
// loadKalibrCamchain; every camera that loads is then used the way
// `lookboth camera info|check|convert` use one.
#include <mrpt/img/TCamera.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/cameras/self_check.h"
#include "lookboth_fuzz.h"

namespace {

using lookboth::Camera;
using lookboth::CameraFileFormat;
namespace fuzz = lookboth::fuzz;

void useCamera(const Camera& camera) {
  (void)camera.description();
  (void)camera.fieldOfView();
  const Eigen::Vector2d centre(0.5 * (camera.width() - 1), 0.5 * (camera.height() - 1));
  for (const Eigen::Vector2d& pixel :
       {centre, Eigen::Vector2d(0, 0), Eigen::Vector2d(camera.width() - 1, camera.height() - 1)}) {
    if (const auto ray = camera.unproject(pixel)) (void)camera.project(*ray);
  }
  lookboth::CameraSelfCheckOptions check;
  check.num_rays = 16;
  check.num_pixels = 16;
  (void)lookboth::selfCheckCamera(camera, check);

  // `lookboth camera convert` writes lookboth's YAML: what it writes for a
  // camera that loaded must load again.
  const std::string yaml = lookboth::cameraToYaml(camera);
  try {
    (void)lookboth::cameraFromYaml(yaml, "converted");
  } catch (const lookboth::Error& e) {
    std::fprintf(stderr,
                 "lookboth-fuzz: a camera that loaded does not load from its own YAML: %s\n%s\n",
                 e.what(), yaml.c_str());
    std::abort();
  }
  fuzz::expectOnlyLookbothErrors([&] { (void)lookboth::toMrptCamera(camera); });
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::installTerminateHandler();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fuzz::fs::path file = fuzz::scratch() / "calibration";
  fuzz::writeBytes(file, data, size);
  for (const CameraFileFormat format :
       {CameraFileFormat::kAuto, CameraFileFormat::kLookboth, CameraFileFormat::kRosCameraInfo,
        CameraFileFormat::kKalibr, CameraFileFormat::kOCamCalib, CameraFileFormat::kOpenCV,
        CameraFileFormat::kCamOdoCal}) {
    fuzz::expectOnlyLookbothErrors([&] { useCamera(lookboth::loadCamera(file, format)); });
  }
  fuzz::expectOnlyLookbothErrors([&] {
    for (const auto& [name, camera] : lookboth::loadKalibrCamchain(file)) useCamera(camera);
  });
  return 0;
}
