// Fuzz target "manifest": the bytes as the manifest (<name>.yaml) of the
// sample rawlog dataset (fuzz_dataset.h), read to the end through
// DatasetReader: the manifest's parser and what the reader does with what
// it says (cameras, trajectories, the expected number of entries).
#include <cstddef>
#include <cstdint>

#include "fuzz_dataset.h"
#include "lookboth_fuzz.h"
#include "read_all.h"

namespace fuzz = lookboth::fuzz;

namespace {

const fuzz::fs::path& rawlogPath() {
  static const fuzz::fs::path path = fuzz::scratch() / "sample.rawlog";
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::installTerminateHandler();
  fuzz::writeSampleRawlog(rawlogPath());
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::writeBytes(lookboth::manifestPathFor(rawlogPath()), data, size);
  fuzz::expectOnlyLookbothErrors([] { fuzz::readWholeDataset(rawlogPath()); });
  return 0;
}
