#include "lookboth/core/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <sstream>

#include "lookboth/core/error.h"
#include "lookboth/core/temporary_files.h"

namespace lookboth {
namespace {

std::filesystem::path temporaryNameFor(const std::filesystem::path& destination) {
  static std::atomic<unsigned> counter{0};
  removeStaleTemporaries(destination.has_parent_path() ? destination.parent_path() : ".");
  std::ostringstream name;
  name << "." << destination.filename().string() << ".tmp-" << ::getpid() << "-" << counter++;
  return destination.parent_path() / name.str();
}

}  // namespace

AtomicOutputFile::AtomicOutputFile(const std::filesystem::path& destination, bool binary)
    : destination_(destination), temporary_(temporaryNameFor(destination)) {
  const std::filesystem::path dir =
      destination.has_parent_path() ? destination.parent_path() : std::filesystem::path(".");
  if (!std::filesystem::is_directory(dir)) {
    throw Error({destination.string(), 0, "", ""},
                "cannot write: directory '" + dir.string() + "' does not exist");
  }
  std::ios::openmode mode = std::ios::out | std::ios::trunc;
  if (binary) mode |= std::ios::binary;
  stream_.open(temporary_, mode);
  if (!stream_) {
    throw Error({destination.string(), 0, "", ""},
                "cannot open a temporary file for writing in '" + dir.string() + "'");
  }
}

AtomicOutputFile::~AtomicOutputFile() {
  if (!committed_) {
    stream_.close();
    std::error_code ignored;
    std::filesystem::remove(temporary_, ignored);
  }
}

void AtomicOutputFile::commit() {
  stream_.flush();
  const bool ok = static_cast<bool>(stream_);
  stream_.close();
  if (!ok || stream_.fail()) {
    std::error_code ignored;
    std::filesystem::remove(temporary_, ignored);
    committed_ = true;
    throw Error({destination_.string(), 0, "", ""}, "write failed (disk full?)");
  }
  std::error_code ec;
  std::filesystem::rename(temporary_, destination_, ec);
  committed_ = true;
  if (ec) {
    std::filesystem::remove(temporary_, ec);
    throw Error({destination_.string(), 0, "", ""}, "cannot rename the finished file into place");
  }
}

void writeDirectoryAtomically(const std::filesystem::path& destination,
                              const std::function<void(const std::filesystem::path&)>& fill) {
  namespace fs = std::filesystem;
  const fs::path target = fs::absolute(destination).lexically_normal();
  const fs::path parent = target.parent_path();
  const std::string stem = target.filename().string();
  removeStaleTemporaries(parent);
  const fs::path temporary = parent / ("." + stem + ".tmp-" + std::to_string(::getpid()));
  fs::remove_all(temporary);
  try {
    fs::create_directories(temporary);
    fill(temporary);
    if (fs::exists(target)) {
      const fs::path old = parent / ("." + stem + ".old-" + std::to_string(::getpid()));
      fs::remove_all(old);
      fs::rename(target, old);
      fs::rename(temporary, target);
      fs::remove_all(old);
    } else {
      fs::rename(temporary, target);
    }
  } catch (...) {
    std::error_code ec;
    fs::remove_all(temporary, ec);
    throw;
  }
}

void writeFileAtomically(const std::filesystem::path& destination, const std::string& contents) {
  AtomicOutputFile out(destination, /*binary=*/true);
  out.stream() << contents;
  out.commit();
}

std::string readFile(const std::filesystem::path& path) {
  if (std::filesystem::is_directory(path)) {
    throw Error({path.string(), 0, "", ""}, "is a directory, expected a file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error({path.string(), 0, "", ""}, "cannot open file for reading");
  std::ostringstream contents;
  contents << in.rdbuf();
  if (in.bad()) throw Error({path.string(), 0, "", ""}, "read error");
  return contents.str();
}

}  // namespace lookboth
