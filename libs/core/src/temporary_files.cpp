#include "lookboth/core/temporary_files.h"

#include <signal.h>

#include <cerrno>
#include <chrono>
#include <mutex>
#include <regex>
#include <set>

namespace lookboth {

namespace fs = std::filesystem;

long temporaryOwner(const std::string& name) {
  static const std::regex pattern(
      R"(^\..+[.-](?:tmp|new)-([0-9]+)(?:-[0-9]+)?(?:\.rawlog|\.yaml|_Images)?$)");
  static const std::regex report(R"(^\.lookboth-report-([0-9]+)-[0-9]+$)");
  std::smatch m;
  if (std::regex_match(name, m, pattern) || std::regex_match(name, m, report)) {
    try {
      return std::stol(m[1].str());
    } catch (...) {
      return 0;
    }
  }
  return 0;
}

namespace {

bool processExists(long pid) {
  if (pid <= 0) return true;
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH;
}

}  // namespace

int removeStaleTemporaries(const fs::path& dir, double min_age_s) {
  static std::mutex mutex;
  static std::set<fs::path> scanned;
  std::error_code ec;
  const fs::path key = fs::absolute(dir.empty() ? fs::path(".") : dir, ec).lexically_normal();
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (!scanned.insert(key).second) return 0;
  }
  int removed = 0;
  const auto now = fs::file_time_type::clock::now();
  for (fs::directory_iterator it(key, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.empty() || name[0] != '.') continue;
    const long owner = temporaryOwner(name);
    if (owner <= 0 || processExists(owner)) continue;
    std::error_code time_ec;
    const auto modified = fs::last_write_time(it->path(), time_ec);
    if (time_ec) continue;
    if (std::chrono::duration<double>(now - modified).count() < min_age_s) continue;
    std::error_code remove_ec;
    if (fs::remove_all(it->path(), remove_ec) > 0 && !remove_ec) ++removed;
  }
  return removed;
}

}  // namespace lookboth
