// Fuzz target "rawlog": the bytes as the .rawlog of a dataset whose manifest
// (without calibrations) and external images are the sample's
// (fuzz_dataset.h), read to the end
// through DatasetReader. Seeds are uncompressed rawlogs: the reader takes
// plain and gzip files alike, and mutating plain serialized objects reaches
// MRPT's and lookboth's deserialization instead of zlib's checksums.
//
// Allocation bound. MRPT trusts the lengths in the file; release builds of
// the reader refuse, while an entry is deserialized, an allocation larger
// than the rest of the file can hold (rawlog_reader.cpp replaces the global
// operator new), but they compile that replacement out under
// AddressSanitizer, so this build would report every corrupt length as an
// out-of-memory crash that release builds turn into an error. This target
// therefore replaces operator new and delete itself (ASan's are weak
// symbols; malloc and free stay ASan's, so heap errors are still caught)
// and refuses, through the reader's own refuseAllocation, what the release
// reader refuses: while an entry is deserialized, one allocation larger
// than the rest of the file can hold or four times that in all. A refusal
// is a std::bad_alloc, as in the release build.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

#include "fuzz_dataset.h"
#include "lookboth_fuzz.h"
#include "read_all.h"

namespace fuzz = lookboth::fuzz;

// rawlog_reader.cpp: the reader's allocation bound, applied per entry.
namespace lookboth::internal {
bool refuseAllocation(std::size_t size);
}

namespace {

void* allocate(std::size_t size, std::size_t alignment) {
  if (lookboth::internal::refuseAllocation(size)) throw std::bad_alloc();
  void* p = nullptr;
  if (alignment <= alignof(std::max_align_t)) {
    p = std::malloc(size == 0 ? 1 : size);
  } else if (posix_memalign(&p, alignment, size == 0 ? 1 : size) != 0) {
    p = nullptr;
  }
  if (!p) throw std::bad_alloc();
  return p;
}

void* allocateNoThrow(std::size_t size, std::size_t alignment) noexcept {
  try {
    return allocate(size, alignment);
  } catch (const std::bad_alloc&) {
    return nullptr;
  }
}

const fuzz::fs::path& rawlogPath() {
  static const fuzz::fs::path path = fuzz::scratch() / "sample.rawlog";
  return path;
}

}  // namespace

constexpr std::size_t kPlain = alignof(std::max_align_t);
void* operator new(std::size_t n) { return allocate(n, kPlain); }
void* operator new[](std::size_t n) { return allocate(n, kPlain); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  return allocateNoThrow(n, kPlain);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  return allocateNoThrow(n, kPlain);
}
void* operator new(std::size_t n, std::align_val_t a) {
  return allocate(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a) {
  return allocate(n, static_cast<std::size_t>(a));
}
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return allocateNoThrow(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return allocateNoThrow(n, static_cast<std::size_t>(a));
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::installTerminateHandler();
  fuzz::writeSampleRawlog(rawlogPath(), /*calibrated=*/false);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::writeBytes(rawlogPath(), data, size);
  fuzz::expectOnlyLookbothErrors([] { fuzz::readWholeDataset(rawlogPath()); });
  return 0;
}
