// Fuzz target "config": the bytes as a lookboth configuration file given
// with --config (sections detect:, odometry:, register:), read by each
// section's loader and checked as the commands check it, and as a ROS bag
// topic mapping (`lookboth convert --mapping`).
#include <cstddef>
#include <cstdint>

#include "lookboth/dataset/rosbag_import.h"
#include "lookboth/detect/detect_dataset.h"
#include "lookboth/pipeline/registration_controller.h"
#include "lookboth/vo/options.h"
#include "lookboth_fuzz.h"

namespace fuzz = lookboth::fuzz;

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::installTerminateHandler();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fuzz::fs::path file = fuzz::scratch() / "config.yaml";
  fuzz::writeBytes(file, data, size);
  fuzz::expectOnlyLookbothErrors([&] { (void)lookboth::loadDetectConfig(file).check(); });
  fuzz::expectOnlyLookbothErrors([&] { (void)lookboth::vo::loadOdometryOptions(file).check(); });
  fuzz::expectOnlyLookbothErrors([&] {
    // The controller builds every configured stage, which checks its options.
    const lookboth::RegistrationController controller(lookboth::loadRegistrationConfig(file));
    (void)controller.config().mergedYaml();
  });
  fuzz::expectOnlyLookbothErrors([&] { (void)lookboth::loadRosbagMapping(file).check(); });
  return 0;
}
