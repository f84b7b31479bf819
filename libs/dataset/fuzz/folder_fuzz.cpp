// Fuzz target "folder": tests/data/datasets/folder_small copied to a scratch
// folder; the first byte of an input picks one of its text files (CSV, TUM,
// YAML, calibration; folderTextFiles order), the rest replaces that file, and
// the folder is read to the end through DatasetReader. The file gets its
// original bytes back after each input.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_dataset.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth_fuzz.h"
#include "read_all.h"

namespace fuzz = lookboth::fuzz;

namespace {

struct Folder {
  fuzz::fs::path root;
  std::vector<fuzz::fs::path> files;
  std::vector<std::string> contents;
};

Folder& folder() {
  static Folder f;
  return f;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::installTerminateHandler();
  Folder& f = folder();
  f.root = fuzz::scratch() / "folder_small";
  fuzz::fs::copy(fuzz::folderSample(), f.root, fuzz::fs::copy_options::recursive);
  f.files = fuzz::folderTextFiles(f.root);
  for (const fuzz::fs::path& file : f.files)
    f.contents.push_back(lookboth::readFile(f.root / file));
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  Folder& f = folder();
  const std::size_t index = data[0] % f.files.size();
  const fuzz::fs::path file = f.root / f.files[index];
  fuzz::writeBytes(file, data + 1, size - 1);
  fuzz::expectOnlyLookbothErrors([&] { fuzz::readWholeDataset(f.root); });
  const std::string& original = f.contents[index];
  fuzz::writeBytes(file, reinterpret_cast<const std::uint8_t*>(original.data()), original.size());
  return 0;
}
