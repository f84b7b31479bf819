// Reading and writing datasets, in either of the two layouts:
//  - rawlog:  <dir>/<name>.rawlog (MRPT observations-only rawlog, gzip),
//             <dir>/<name>.yaml (manifest), <dir>/<name>_Images/ (external images);
//  - folder:  the plain interchange layout of doc/formats.md.
// Readers stream: memory stays flat however long the recording.
// Writers write under temporary names and move everything into place in
// `finish()`; a writer destroyed without `finish()` leaves nothing behind.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/records.h"

namespace lookboth {

enum class DatasetKind { kRawlog, kFolder };
const char* datasetKindName(DatasetKind kind);

/// kRawlog for "x.rawlog" (or its manifest "x.yaml" when "x.rawlog" exists
/// beside it), kFolder for a directory or a path with no extension. Throws
/// lookboth::Error naming the path otherwise.
DatasetKind detectDatasetKind(const std::filesystem::path& path);

/// A problem in the input that does not stop reading (a duplicated
/// timestamp, a missing image...): the record concerned is skipped. Or, with
/// `note`, a fact worth telling that skips nothing (frames a video recorder
/// dropped): never an error, even when reading strictly.
struct DatasetIssue {
  std::string where;  ///< "x.rawlog: entry 1234" or "cameras/cam03/frames.csv:17".
  std::string message;
  bool note = false;
};

struct DatasetReadOptions {
  /// Turn every issue into an error (lookboth::Error) instead of a warning.
  bool strict = false;
  /// Check that image files exist when a frame is read (costs a stat per frame).
  bool check_images = true;
  /// Called for every issue as it is found (e.g. to print warnings).
  std::function<void(const DatasetIssue&)> on_issue;
};

class DatasetReader {
 public:
  /// Opens a rawlog dataset (path of the .rawlog or of its manifest) or a folder.
  static std::unique_ptr<DatasetReader> open(const std::filesystem::path& path,
                                             const DatasetReadOptions& options = {});
  virtual ~DatasetReader() = default;

  const Manifest& manifest() const { return manifest_; }
  const std::filesystem::path& path() const { return path_; }
  DatasetKind kind() const { return kind_; }

  /// The next record (in file order for rawlogs, time order for folders), or
  /// nullopt at the end. Throws lookboth::Error, naming the file and entry, on
  /// input that cannot be read past (truncation, unknown class...); every
  /// record returned before stays valid.
  virtual std::optional<Record> next() = 0;

  /// Records expected in all, for progress; -1 when unknown.
  virtual std::int64_t expectedCount() const { return -1; }
  /// Issues found so far.
  const std::vector<DatasetIssue>& issues() const { return issues_; }

 protected:
  DatasetReader(std::filesystem::path path, DatasetKind kind, DatasetReadOptions options)
      : path_(std::move(path)), kind_(kind), options_(std::move(options)) {}
  /// Records an issue (or throws in strict mode).
  void reportIssue(const std::string& where, const std::string& message);
  /// Records a note (DatasetIssue::note): never throws; `on_issue` hears
  /// each note once per process however often the dataset is read.
  void reportNote(const std::string& where, const std::string& message);

  Manifest manifest_;
  std::filesystem::path path_;
  DatasetKind kind_;
  DatasetReadOptions options_;
  std::vector<DatasetIssue> issues_;
};

struct DatasetWriteOptions {
  bool overwrite = false;  ///< Replace an existing output; otherwise refuse it.
  /// Image files (ImageFrame::image_file) are hard-linked into the output
  /// instead of copied (falls back to a copy across file systems). The
  /// bytes are then shared: never use it when the output may be edited in place.
  bool link_images = false;
};

class DatasetWriter {
 public:
  /// Starts a dataset at `path` (the .rawlog for kRawlog, the folder for
  /// kFolder). Throws lookboth::Error when the output exists (and not
  /// overwrite), its directory does not, or the manifest is inconsistent.
  static std::unique_ptr<DatasetWriter> create(const std::filesystem::path& path, DatasetKind kind,
                                               const Manifest& manifest,
                                               const DatasetWriteOptions& options = {});
  virtual ~DatasetWriter() = default;

  /// Appends a record. Image bytes are copied (or written from
  /// `ImageFrame::encoded`) unchanged into the dataset's image folder.
  virtual void write(const Record& record) = 0;
  /// Completes the dataset and moves it into place. `manifest` may differ
  /// from the one given at creation (e.g. trajectories added on the way).
  virtual void finish(const Manifest& manifest) = 0;
  void finish() { finish(manifest_); }

  std::int64_t recordsWritten() const { return records_written_; }

 protected:
  explicit DatasetWriter(Manifest manifest) : manifest_(std::move(manifest)) {}
  Manifest manifest_;
  std::int64_t records_written_ = 0;
};

/// A dataset's manifest and its marker detections (every id, in the
/// dataset's order), read in one pass without checking its images: what
/// `export` and `align` need of a registered dataset.
struct MarkerDetections {
  Manifest manifest;
  std::vector<MarkerObservation> detections;
};
MarkerDetections readMarkerDetections(const std::filesystem::path& dataset);

/// The manifest path of a rawlog dataset: <dir>/<stem>.yaml.
std::filesystem::path manifestPathFor(const std::filesystem::path& rawlog);
/// MRPT's external images folder of a rawlog: <dir>/<stem>_Images (computed
/// here: MRPT 2.5.8's CRawlog::detectImagesDirectory is wrong for absolute paths).
std::filesystem::path imagesDirectoryFor(const std::filesystem::path& rawlog);
/// Every file or folder a dataset given by `path` consists of (a rawlog's
/// .rawlog, manifest and images folder; a folder itself), for checking that
/// an output does not overwrite one. Never throws.
std::vector<std::filesystem::path> datasetPaths(const std::filesystem::path& path);

}  // namespace lookboth
