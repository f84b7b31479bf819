// Fuzz target "rosbag": the bytes as a ROS 1 bag, imported into a folder
// dataset with the seed bag's topic mapping (fuzz_dataset.h) the way
// `lookboth convert --from x.bag` does.
#include <cstddef>
#include <cstdint>

#include "fuzz_dataset.h"
#include "lookboth_fuzz.h"

namespace fuzz = lookboth::fuzz;

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::installTerminateHandler();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const lookboth::RosbagImportOptions options = fuzz::fuzzBagOptions();
  const fuzz::fs::path bag = fuzz::scratch() / "input.bag";
  fuzz::writeBytes(bag, data, size);
  lookboth::DatasetWriteOptions write_options;
  write_options.overwrite = true;
  fuzz::expectOnlyLookbothErrors([&] {
    (void)lookboth::importRosbag(bag, fuzz::scratch() / "imported", lookboth::DatasetKind::kFolder,
                                 options, write_options, lookboth::ProgressReporter());
  });
  return 0;
}
