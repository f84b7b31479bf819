// An exclusive lock on a dataset (or any file or folder) while it is being
// rewritten, so that two writers never rewrite it at once: each reads the
// dataset as the other left it, and neither's additions are lost.
//
// The lock is an advisory flock(2) on a hidden file beside the path,
// ".<name>.lock", held by an open descriptor: the kernel releases it when
// the process ends however it ends (Ctrl-C, SIGKILL, a crash), so a stale
// lock never blocks a later run. The file is removed on release.
#pragma once

#include <filesystem>
#include <functional>

namespace lookboth {

class ProgressReporter;

class PathLock {
 public:
  /// Takes the lock on `path`, waiting while another process holds it.
  /// `on_wait` (may be empty) is called once when the lock is busy, to tell
  /// the user why nothing happens. Throws StopRequested if a stop is
  /// requested while waiting, lookboth::Error when the lock file cannot be
  /// created (a read-only folder: then nothing can be rewritten there either).
  PathLock(const std::filesystem::path& path, const ProgressReporter& progress,
           const std::function<void()>& on_wait = {});
  /// Takes the lock if it is free; `locked()` says whether it was.
  explicit PathLock(const std::filesystem::path& path);
  ~PathLock();
  PathLock(const PathLock&) = delete;
  PathLock& operator=(const PathLock&) = delete;

  bool locked() const { return fd_ >= 0; }
  /// ".<name>.lock" beside `path`.
  static std::filesystem::path lockFileFor(const std::filesystem::path& path);

 private:
  bool tryLock();
  std::filesystem::path lock_file_;
  int fd_ = -1;
};

}  // namespace lookboth
