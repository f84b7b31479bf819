#include "lookboth/dataset/dataset_io.h"

#include <unistd.h>

#include <atomic>
#include <mutex>
#include <set>

#include "internal.h"
#include "lookboth/core/error.h"
#include "lookboth/core/temporary_files.h"

namespace lookboth {

namespace fs = std::filesystem;

const char* datasetKindName(DatasetKind kind) {
  return kind == DatasetKind::kRawlog ? "rawlog" : "folder";
}

fs::path manifestPathFor(const fs::path& rawlog) {
  return rawlog.parent_path() / (rawlog.stem().string() + ".yaml");
}

fs::path imagesDirectoryFor(const fs::path& rawlog) {
  return rawlog.parent_path() / (rawlog.stem().string() + "_Images");
}

std::vector<fs::path> datasetPaths(const fs::path& path) {
  DatasetKind kind = DatasetKind::kFolder;
  try {
    kind = detectDatasetKind(path);
  } catch (const Error&) {
    return {path};
  }
  if (kind == DatasetKind::kFolder) return {path};
  const fs::path rawlog = path.extension() == ".rawlog"
                              ? path
                              : path.parent_path() / (path.stem().string() + ".rawlog");
  return {rawlog, manifestPathFor(rawlog), imagesDirectoryFor(rawlog)};
}

DatasetKind detectDatasetKind(const fs::path& path) {
  if (fs::is_directory(path)) return DatasetKind::kFolder;
  const std::string ext = path.extension().string();
  if (ext == ".rawlog") return DatasetKind::kRawlog;
  if ((ext == ".yaml" || ext == ".yml") &&
      fs::exists(path.parent_path() / (path.stem().string() + ".rawlog"))) {
    return DatasetKind::kRawlog;
  }
  if (ext.empty()) return DatasetKind::kFolder;
  throw Error({path.string(), 0, "", ""},
              "not a dataset: expected a .rawlog file (with its manifest beside it) or a folder");
}

void DatasetReader::reportIssue(const std::string& where, const std::string& message) {
  DatasetIssue issue{where, message};
  if (options_.strict) throw Error(where + ": " + message);
  if (options_.on_issue) options_.on_issue(issue);
  issues_.push_back(std::move(issue));
}

void DatasetReader::reportNote(const std::string& where, const std::string& message) {
  DatasetIssue note{where, message, true};
  // A command reads its dataset several times (detect, odometry, the
  // stages): a note is told once per process, and kept in every reader's issues().
  static std::mutex mutex;
  static std::set<std::string> told;
  if (options_.on_issue) {  // told only by a reader that tells it
    bool first = false;
    {
      const std::lock_guard<std::mutex> lock(mutex);
      first = told.insert(where + '\n' + message).second;
    }
    if (first) options_.on_issue(note);
  }
  issues_.push_back(std::move(note));
}

MarkerDetections readMarkerDetections(const fs::path& dataset) {
  DatasetReadOptions options;
  options.check_images = false;
  const std::unique_ptr<DatasetReader> reader = DatasetReader::open(dataset, options);
  MarkerDetections result;
  result.manifest = reader->manifest();
  while (const std::optional<Record> record = reader->next()) {
    if (const auto* marker = std::get_if<MarkerObservation>(&*record)) {
      result.detections.push_back(*marker);
    }
  }
  return result;
}

std::unique_ptr<DatasetReader> DatasetReader::open(const fs::path& path,
                                                   const DatasetReadOptions& options) {
  if (!fs::exists(path)) throw Error({path.string(), 0, "", ""}, "no such file or folder");
  if (detectDatasetKind(path) == DatasetKind::kFolder)
    return internal::openFolderReader(path, options);
  fs::path rawlog = path;
  if (path.extension() != ".rawlog")
    rawlog = path.parent_path() / (path.stem().string() + ".rawlog");
  return internal::openRawlogReader(rawlog, options);
}

std::unique_ptr<DatasetWriter> DatasetWriter::create(const fs::path& path, DatasetKind kind,
                                                     const Manifest& manifest,
                                                     const DatasetWriteOptions& options) {
  if (const std::string why = manifest.check(); !why.empty()) {
    throw Error({path.string(), 0, "", ""}, "inconsistent manifest: " + why);
  }
  if (kind == DatasetKind::kRawlog) {
    if (path.extension() != ".rawlog") {
      throw Error({path.string(), 0, "", ""}, "a rawlog dataset must be named <name>.rawlog");
    }
    return internal::createRawlogWriter(path, manifest, options);
  }
  return internal::createFolderWriter(path, manifest, options);
}

namespace internal {

fs::path temporarySibling(const fs::path& destination) {
  static std::atomic<unsigned> counter{0};
  const fs::path parent = destination.has_parent_path() ? destination.parent_path() : fs::path(".");
  removeStaleTemporaries(parent);
  return parent / ("." + destination.filename().string() + ".tmp-" + std::to_string(::getpid()) +
                   "-" + std::to_string(counter++));
}

void checkOutputPath(const fs::path& destination, bool overwrite) {
  const fs::path parent = destination.has_parent_path() ? destination.parent_path() : fs::path(".");
  if (!fs::is_directory(parent)) {
    throw Error({destination.string(), 0, "", ""},
                "cannot write: directory '" + parent.string() + "' does not exist");
  }
  if (fs::exists(destination) && !overwrite) {
    throw Error({destination.string(), 0, "", ""},
                "already exists (use --overwrite to replace it)");
  }
}

void moveIntoPlace(const fs::path& temporary, const fs::path& destination, bool overwrite) {
  std::error_code ec;
  if (fs::exists(destination)) {
    if (!overwrite) {
      fs::remove_all(temporary, ec);
      throw Error({destination.string(), 0, "", ""}, "appeared while writing; not replaced");
    }
    // Move the old one aside first, so that a failure leaves one complete copy.
    const fs::path old = temporarySibling(destination);
    fs::rename(destination, old, ec);
    if (ec) throw Error({destination.string(), 0, "", ""}, "cannot replace: " + ec.message());
    fs::rename(temporary, destination, ec);
    if (ec) {
      std::error_code ignored;
      fs::rename(old, destination, ignored);
      throw Error({destination.string(), 0, "", ""}, "cannot move into place: " + ec.message());
    }
    fs::remove_all(old, ec);
    return;
  }
  fs::rename(temporary, destination, ec);
  if (ec) throw Error({destination.string(), 0, "", ""}, "cannot move into place: " + ec.message());
}

void placeImageFile(const fs::path& source, const fs::path& target, bool link,
                    const std::string& subject) {
  std::error_code ec;
  if (link) {
    fs::create_hard_link(source, target, ec);
    if (!ec) return;
    ec.clear();
  }
  fs::copy_file(source, target, ec);
  if (ec) throw Error({source.string(), 0, "", subject}, "cannot copy the file: " + ec.message());
}

}  // namespace internal
}  // namespace lookboth
