#include "lookboth/core/file_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <thread>

#include "lookboth/core/error.h"
#include "lookboth/core/progress.h"

namespace lookboth {

namespace fs = std::filesystem;

fs::path PathLock::lockFileFor(const fs::path& path) {
  fs::path target = path;
  if (!target.has_filename() && target.has_parent_path()) target = target.parent_path();
  const fs::path parent = target.has_parent_path() ? target.parent_path() : fs::path(".");
  return parent / ("." + target.filename().string() + ".lock");
}

bool PathLock::tryLock() {
  for (;;) {
    const int fd = ::open(lock_file_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) {
      throw Error({lock_file_.string(), 0, "", ""},
                  std::string("cannot create the lock file: ") + std::strerror(errno));
    }
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd);
      return false;
    }
    // The previous holder may have removed the file between our open and our
    // flock: then we hold a lock on a file nobody else can find. Retry on the
    // file that is there now.
    struct stat held {};
    struct stat named {};
    if (::fstat(fd, &held) == 0 && ::stat(lock_file_.c_str(), &named) == 0 &&
        held.st_ino == named.st_ino && held.st_dev == named.st_dev) {
      fd_ = fd;
      return true;
    }
    ::close(fd);
  }
}

PathLock::PathLock(const fs::path& path, const ProgressReporter& progress,
                   const std::function<void()>& on_wait)
    : lock_file_(lockFileFor(path)) {
  bool told = false;
  while (!tryLock()) {
    if (!told && on_wait) on_wait();
    told = true;
    progress.checkStop();
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

PathLock::PathLock(const fs::path& path) : lock_file_(lockFileFor(path)) { tryLock(); }

PathLock::~PathLock() {
  if (fd_ < 0) return;
  // Unlink while holding the lock, so a waiter that opened this file sees the
  // inode change and retries on a fresh one.
  ::unlink(lock_file_.c_str());
  ::close(fd_);
}

}  // namespace lookboth
