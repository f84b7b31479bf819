#include "lookboth/core/paths.h"

#include <cstdlib>
#include <string>
#include <vector>

#include "lookboth/core/error.h"

namespace lookboth {

std::filesystem::path shareDirectory() {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("LOOKBOTH_SHARE_DIR"); env && *env)
    candidates.emplace_back(env);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path().parent_path() / "share" / "lookboth");
  candidates.emplace_back(LOOKBOTH_SOURCE_SHARE_DIR);
  for (const fs::path& candidate : candidates) {
    if (fs::is_directory(candidate / "cameras", ec)) return candidate;
  }
  std::string tried;
  for (const fs::path& candidate : candidates) tried += " " + candidate.string();
  throw Error("cannot find lookboth's share directory (tried:" + tried +
              "); set LOOKBOTH_SHARE_DIR");
}

}  // namespace lookboth
