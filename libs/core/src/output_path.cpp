#include "lookboth/core/output_path.h"

#include "lookboth/core/error.h"

namespace lookboth {

namespace fs = std::filesystem;

namespace {

fs::path normalised(const fs::path& path) {
  std::error_code ec;
  fs::path absolute = fs::weakly_canonical(path, ec);
  if (ec) absolute = fs::absolute(path, ec).lexically_normal();
  // "dir/" and "dir" are the same folder.
  if (!absolute.has_filename() && absolute.has_parent_path()) absolute = absolute.parent_path();
  return absolute;
}

}  // namespace

bool sameFile(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::exists(a, ec) && fs::exists(b, ec)) {
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  return normalised(a) == normalised(b);
}

bool contains(const fs::path& ancestor, const fs::path& path) {
  const fs::path outer = normalised(ancestor);
  fs::path inner = normalised(path);
  while (inner.has_parent_path() && inner.parent_path() != inner) {
    inner = inner.parent_path();
    if (inner == outer) return true;
    std::error_code ec;
    if (fs::exists(inner, ec) && fs::exists(ancestor, ec) && fs::equivalent(inner, ancestor, ec))
      return true;
  }
  return false;
}

void checkOutputPath(const fs::path& output, const std::vector<fs::path>& inputs, bool overwrite,
                     const std::string& option) {
  const ErrorContext where{output.string(), 0, option, ""};
  for (const fs::path& input : inputs) {
    if (input.empty()) continue;
    if (sameFile(output, input)) {
      throw Error(where, "is the input '" + input.string() +
                             "'; inputs are never written to: choose another path");
    }
    if (contains(output, input)) {
      throw Error(where, "contains the input '" + input.string() +
                             "'; replacing it would delete the input: choose another path");
    }
  }
  std::error_code ec;
  if (!overwrite && fs::exists(fs::symlink_status(output, ec))) {
    throw Error(where, "already exists (use --overwrite to replace it)");
  }
}

}  // namespace lookboth
