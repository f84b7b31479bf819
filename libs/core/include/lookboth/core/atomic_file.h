// Outputs are written under a temporary name beside their destination and
// renamed into place only when complete, so an interrupted run never leaves a
// truncated file under the final name, and an existing file is replaced
// atomically (POSIX rename within one directory).
#pragma once

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

namespace lookboth {

/// A file being written. Write through `stream()`, then call `commit()`.
/// If the object is destroyed without `commit()` (an exception, an
/// interruption), the temporary file is removed and the destination is left
/// as it was.
class AtomicOutputFile {
 public:
  /// Opens "<dir>/.<name>.tmp-<pid>-<n>" for writing. Throws lookboth::Error
  /// naming `destination` when the directory does not exist or is not writable.
  explicit AtomicOutputFile(const std::filesystem::path& destination, bool binary = false);
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;

  std::ostream& stream() { return stream_; }
  const std::filesystem::path& destination() const { return destination_; }
  const std::filesystem::path& temporaryPath() const { return temporary_; }

  /// Flushes, closes and renames the temporary file onto the destination.
  /// Throws lookboth::Error if writing or renaming failed.
  void commit();

 private:
  std::filesystem::path destination_;
  std::filesystem::path temporary_;
  std::ofstream stream_;
  bool committed_ = false;
};

/// Writes `contents` to `destination` atomically (see AtomicOutputFile).
void writeFileAtomically(const std::filesystem::path& destination, const std::string& contents);

/// Writes a folder atomically: `fill` writes its files into a temporary
/// folder beside `destination` (".<name>.tmp-<pid>"), which is then renamed
/// onto `destination`, replacing an existing one (kept as ".<name>.old-<pid>"
/// until the rename is done). On an exception the temporary is removed and
/// `destination` is left as it was. The caller checks `--overwrite`.
void writeDirectoryAtomically(const std::filesystem::path& destination,
                              const std::function<void(const std::filesystem::path&)>& fill);

/// Reads a whole file. Throws lookboth::Error naming the file if it cannot be read.
std::string readFile(const std::filesystem::path& path);

}  // namespace lookboth
