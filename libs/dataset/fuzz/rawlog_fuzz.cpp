// Fuzz target "rawlog": the bytes as the .rawlog of a dataset whose manifest
// and external images are the sample's (fuzz_dataset.h), read to the end
// through DatasetReader. Seeds are uncompressed rawlogs: the reader takes
// plain and gzip files alike, and mutating plain serialized objects reaches
// MRPT's and lookboth's deserialization instead of zlib's checksums.
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
  fuzz::writeBytes(rawlogPath(), data, size);
  fuzz::expectOnlyLookbothErrors([] { fuzz::readWholeDataset(rawlogPath()); });
  return 0;
}
