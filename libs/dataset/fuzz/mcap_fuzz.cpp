// Fuzz target "mcap": the bytes as a ROS 2 bag in one MCAP file, imported
// into a rawlog dataset with the fixtures' topic mapping (fuzz_dataset.h) the
// way `lookboth convert --from x.mcap` does: the MCAP records and chunks
// (lz4, zstd), then the CDR messages.
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
  static const lookboth::RosbagImportOptions options = fuzz::fuzzRos2Options();
  const fuzz::fs::path bag = fuzz::scratch() / "input.mcap";
  fuzz::writeBytes(bag, data, size);
  lookboth::DatasetWriteOptions write_options;
  write_options.overwrite = true;
  fuzz::expectOnlyLookbothErrors([&] {
    (void)lookboth::importRosbag(bag, fuzz::scratch() / "imported.rawlog",
                                 lookboth::DatasetKind::kRawlog, options, write_options,
                                 lookboth::ProgressReporter());
  });
  return 0;
}
