#include "lookboth/dataset/augment.h"

#include <unistd.h>

#include <algorithm>
#include <queue>
#include <set>

#include "internal.h"
#include "lookboth/core/error.h"
#include "lookboth/core/file_lock.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/temporary_files.h"
#include "lookboth/core/text.h"

namespace lookboth {

namespace fs = std::filesystem;

namespace {

/// The .rawlog of a rawlog dataset given by its .rawlog or manifest path.
fs::path rawlogPath(const fs::path& path) {
  if (path.extension() == ".rawlog") return path;
  return path.parent_path() / (path.stem().string() + ".rawlog");
}

/// The files and folders that make a dataset at `path` (rawlog: manifest,
/// rawlog, images; folder: itself), in the order they must be moved aside
/// (the manifest first: a rawlog without its manifest is incomplete).
std::vector<fs::path> datasetParts(const fs::path& path, DatasetKind kind) {
  if (kind == DatasetKind::kFolder) return {path};
  return {manifestPathFor(path), path, imagesDirectoryFor(path)};
}

/// A rawlog path "<dir>/.<stem>.<tag>-<pid>-<n>.rawlog" beside `rawlog` (a folder path for
/// folders).
fs::path hiddenSibling(const fs::path& path, DatasetKind kind, const std::string& tag) {
  static int counter = 0;
  const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
  removeStaleTemporaries(dir);
  const std::string stem = "." + path.stem().string() + "." + tag + "-" +
                           std::to_string(::getpid()) + "-" + std::to_string(counter++);
  return dir / (kind == DatasetKind::kRawlog ? stem + ".rawlog" : stem);
}

void renameOrThrow(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::rename(from, to, ec);
  if (ec) {
    throw Error({to.string(), 0, "", ""},
                "cannot move '" + from.string() + "' into place: " + ec.message());
  }
}

/// Replaces the complete dataset at `destination` by the complete dataset at
/// `fresh` (same kind): old parts aside, new parts in (manifest last), old removed.
void swapDataset(const fs::path& fresh, const fs::path& destination, DatasetKind kind) {
  const std::vector<fs::path> new_parts = datasetParts(fresh, kind);
  const std::vector<fs::path> old_parts = datasetParts(destination, kind);
  const std::vector<fs::path> aside_parts =
      datasetParts(hiddenSibling(destination, kind, "old"), kind);
  std::vector<bool> moved(old_parts.size(), false);
  for (std::size_t i = 0; i < old_parts.size(); ++i) {
    if (!fs::exists(old_parts[i])) continue;
    renameOrThrow(old_parts[i], aside_parts[i]);
    moved[i] = true;
  }
  // New parts in: images, rawlog, then the manifest (reverse order).
  for (std::size_t k = new_parts.size(); k-- > 0;) {
    if (fs::exists(new_parts[k])) renameOrThrow(new_parts[k], old_parts[k]);
  }
  std::error_code ignored;
  for (std::size_t i = 0; i < aside_parts.size(); ++i) {
    if (moved[i]) fs::remove_all(aside_parts[i], ignored);
  }
}

/// Removes whatever exists of a dataset (a failed or stopped temporary output).
void removeDataset(const fs::path& path, DatasetKind kind) {
  std::error_code ignored;
  for (const fs::path& part : datasetParts(path, kind)) fs::remove_all(part, ignored);
}

/// The path that names the dataset `options` rewrites (its .rawlog, or its folder).
fs::path lockTargetOf(const AugmentOptions& options) {
  const DatasetKind kind = detectDatasetKind(options.input);
  const fs::path input = kind == DatasetKind::kRawlog ? rawlogPath(options.input) : options.input;
  if (options.output.empty()) return input;
  return kind == DatasetKind::kRawlog ? rawlogPath(options.output) : options.output;
}

std::int64_t stepOf(std::int64_t expected) { return std::max<std::int64_t>(1, expected / 200); }

}  // namespace

std::string AugmentOptions::check() const {
  if (input.empty()) return "'input': no dataset given";
  return "";
}

AugmentSummary augmentDataset(const AugmentOptions& options, std::vector<Record> added,
                              const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  // One writer at a time per destination, from before the input is read
  // until the new dataset is in place: a second run reads what the first
  // wrote, so neither's additions are lost.
  if (!fs::exists(options.input))
    throw Error({options.input.string(), 0, "", ""}, "no such file or folder");
  const fs::path lock_target = lockTargetOf(options);
  const PathLock lock(lock_target, progress, [&] {
    if (options.on_issue) {
      options.on_issue(
          {lock_target.string(), "another lookboth run is rewriting it; waiting for it to finish"});
    }
  });
  DatasetReadOptions read_options;
  read_options.on_issue = options.on_issue;
  std::unique_ptr<DatasetReader> reader = DatasetReader::open(options.input, read_options);
  const DatasetKind kind = reader->kind();
  const fs::path input =
      kind == DatasetKind::kRawlog ? rawlogPath(options.input) : fs::path(options.input);
  const bool in_place =
      options.output.empty() || sameFile(options.output, input) ||
      (kind == DatasetKind::kRawlog && sameFile(rawlogPath(options.output), input));
  fs::path destination = in_place ? input : options.output;
  if (!in_place) {
    if (detectDatasetKind(destination) != kind) {
      throw Error(
          {destination.string(), 0, "", ""},
          std::string("the output must have the input's layout (") + datasetKindName(kind) + ")");
    }
    for (const fs::path& part : datasetParts(destination, kind)) {
      internal::checkOutputPath(part, options.overwrite);
    }
  }
  Manifest manifest = options.manifest ? *options.manifest : reader->manifest();
  if (kind == DatasetKind::kRawlog) manifest.name = destination.stem().string();
  for (const Record& record : added) {
    const std::string& label = recordLabel(record);
    if (!std::holds_alternative<PoseSample>(record) && !manifest.findCamera(label)) {
      throw Error({input.string(), 0, "", label},
                  std::string("cannot add a ") + recordKindName(record) +
                      " record of a camera that the manifest does not list");
    }
  }
  std::stable_sort(added.begin(), added.end(),
                   [](const Record& a, const Record& b) { return recordTime(a) < recordTime(b); });

  // The new dataset, complete, under a hidden name beside the destination.
  const fs::path fresh = hiddenSibling(destination, kind, "new");
  AugmentSummary summary;
  summary.output = destination;
  try {
    DatasetWriteOptions write_options;
    write_options.link_images = options.link_images;
    std::unique_ptr<DatasetWriter> writer =
        DatasetWriter::create(fresh, kind, manifest, write_options);
    std::size_t next_added = 0;
    const std::int64_t expected = reader->expectedCount();
    const std::int64_t step = stepOf(expected);
    std::int64_t read = 0;
    while (std::optional<Record> record = reader->next()) {
      const TimeNs t = recordTime(*record);
      while (next_added < added.size() && recordTime(added[next_added]) < t) {
        writer->write(added[next_added++]);
        ++summary.added;
      }
      if (options.drop && options.drop(*record)) {
        ++summary.dropped;
      } else {
        writer->write(*record);
        ++summary.copied;
      }
      if (++read % step == 0) {
        progress.checkStop();
        progress.report("write dataset", read, expected > 0 ? expected : 0);
      }
    }
    for (; next_added < added.size(); ++next_added) {
      writer->write(added[next_added]);
      ++summary.added;
    }
    progress.checkStop();
    summary.issues = reader->issues();
    reader.reset();  // closed before the swap
    writer->finish(manifest);
    progress.report("write dataset", read, read);
  } catch (...) {
    removeDataset(fresh, kind);
    throw;
  }
  // From here on the new dataset is complete: no more stop checks.
  try {
    swapDataset(fresh, destination, kind);
  } catch (...) {
    removeDataset(fresh, kind);
    throw;
  }
  return summary;
}

std::string recordKey(const Record& record) {
  std::string key = std::string(recordKindName(record)) + "/" + recordLabel(record) + "/" +
                    std::to_string(recordTime(record));
  if (const auto* marker = std::get_if<MarkerObservation>(&record)) {
    key += "/" + std::to_string(marker->marker_id);
  }
  return key;
}

namespace {

bool sameCalibration(const std::optional<Camera>& a, const std::optional<Camera>& b) {
  if (!a || !b) return !a && !b;
  return a->modelName() == b->modelName() && a->width() == b->width() &&
         a->height() == b->height() && a->params() == b->params();
}

/// Adds to `into` (the first input's manifest) the cameras and ground truth
/// of another input: shards of one recording or edge nodes' results, each
/// with some of the site's cameras. A camera both list must agree (role,
/// calibration), and so must the marker. Throws lookboth::Error naming the
/// input and the camera or field.
void mergeManifest(const Manifest& other, const fs::path& other_path, const fs::path& first_path,
                   Manifest* into) {
  const MarkerSpec& a = into->marker;
  const MarkerSpec& b = other.marker;
  if (a.dictionary != b.dictionary || a.id != b.id || a.size_m != b.size_m) {
    throw Error({other_path.string(), 0, "marker", ""},
                "another marker than '" + first_path.string() + "''s (" + b.dictionary + " id " +
                    std::to_string(b.id) + ", " + formatDouble(b.size_m) + " m against " +
                    a.dictionary + " id " + std::to_string(a.id) + ", " + formatDouble(a.size_m) +
                    " m): not the same recording");
  }
  for (const CameraSensor& camera : other.cameras) {
    const CameraSensor* known = into->findCamera(camera.label);
    if (!known) {
      if (camera.role == SensorRole::kFisheye && into->fisheye()) {
        throw Error({other_path.string(), 0, "cameras", camera.label},
                    "a second fisheye (the first input's is '" + into->fisheye()->label + "')");
      }
      // The fisheye first, then the environment cameras in the order they come.
      auto at = camera.role == SensorRole::kFisheye ? into->cameras.begin() : into->cameras.end();
      into->cameras.insert(at, camera);
      continue;
    }
    if (known->role != camera.role || !sameCalibration(known->camera, camera.camera)) {
      throw Error({other_path.string(), 0, "cameras", camera.label},
                  "differs from the same camera in '" + first_path.string() + "' (" +
                      (camera.camera ? camera.camera->description() : "no calibration") +
                      " against " + (known->camera ? known->camera->description() : "none") +
                      "): not the same recording, or a camera calibrated again");
    }
  }
  GroundTruth& truth = into->ground_truth;
  truth.world_from_camera.insert(other.ground_truth.world_from_camera.begin(),
                                 other.ground_truth.world_from_camera.end());
  for (const auto& [label, spans] : other.ground_truth.hidden_from_fisheye) {
    const auto known = truth.hidden_from_fisheye.find(label);
    const auto same = [](const TimeSpan& a, const TimeSpan& b) {
      return a.begin == b.begin && a.end == b.end;
    };
    if (known != truth.hidden_from_fisheye.end() &&
        !std::equal(known->second.begin(), known->second.end(), spans.begin(), spans.end(), same)) {
      throw Error({other_path.string(), 0, "hidden_from_fisheye", label},
                  "hidden from the fisheye at other times than in '" + first_path.string() +
                      "': not the same recording");
    }
    truth.hidden_from_fisheye.emplace(label, spans);
  }
  // Times of two inputs are comparable only when their clocks are described alike.
  for (const auto& [label, offset] : other.ground_truth.clock_offset) {
    const auto known = truth.clock_offset.find(label);
    if (known != truth.clock_offset.end() && known->second != offset) {
      throw Error({other_path.string(), 0, "clock_offset", label},
                  "clock offset " + std::to_string(offset) + " ns against " +
                      std::to_string(known->second) + " ns in '" + first_path.string() +
                      "': not the same recording, or the node's clock described differently");
    }
    truth.clock_offset.emplace(label, offset);
  }
  if (!truth.fisheye_from_marker)
    truth.fisheye_from_marker = other.ground_truth.fisheye_from_marker;
}

}  // namespace

std::string MergeOptions::check() const {
  if (inputs.size() < 2) return "'inputs': give at least two datasets to merge";
  if (output.empty()) return "'output': no output given";
  for (const fs::path& input : inputs) {
    if (sameFile(input, output)) {
      return "'output': '" + output.string() + "' is also an input";
    }
  }
  return "";
}

MergeSummary mergeDatasets(const MergeOptions& options, const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  DatasetReadOptions read_options;
  read_options.on_issue = options.on_issue;
  std::vector<std::unique_ptr<DatasetReader>> readers;
  for (const fs::path& input : options.inputs) {
    readers.push_back(DatasetReader::open(input, read_options));
  }
  Manifest manifest = readers.front()->manifest();
  std::int64_t expected = 0;
  for (std::size_t i = 0; i < readers.size(); ++i) {
    const Manifest& other = readers[i]->manifest();
    expected += std::max<std::int64_t>(0, readers[i]->expectedCount());
    if (i == 0) continue;
    mergeManifest(other, options.inputs[i], options.inputs[0], &manifest);
    for (const TrajectoryInfo& trajectory : other.trajectories) {
      if (!manifest.findTrajectory(trajectory.label)) manifest.trajectories.push_back(trajectory);
    }
  }
  const DatasetKind kind = detectDatasetKind(options.output);
  if (kind == DatasetKind::kRawlog) manifest.name = options.output.stem().string();
  MergeSummary summary;
  DatasetWriteOptions write_options;
  write_options.overwrite = options.overwrite;
  write_options.link_images = options.link_images;
  std::unique_ptr<DatasetWriter> writer =
      DatasetWriter::create(options.output, kind, manifest, write_options);

  // k-way merge on (time, input index); keys written recently remembered for
  // deduplication (a window of 10 s behind the newest time written).
  struct Head {
    TimeNs t;
    std::size_t input;
    bool operator>(const Head& o) const { return t != o.t ? t > o.t : input > o.input; }
  };
  std::vector<std::optional<Record>> heads(readers.size());
  std::priority_queue<Head, std::vector<Head>, std::greater<Head>> queue;
  for (std::size_t i = 0; i < readers.size(); ++i) {
    heads[i] = readers[i]->next();
    if (heads[i]) queue.push({recordTime(*heads[i]), i});
  }
  std::map<TimeNs, std::set<std::string>> recent;
  const TimeNs window = secondsToNs(10);
  std::int64_t done = 0;
  const std::int64_t step = stepOf(expected);
  while (!queue.empty()) {
    const Head head = queue.top();
    queue.pop();
    Record record = std::move(*heads[head.input]);
    heads[head.input] = readers[head.input]->next();
    if (heads[head.input]) queue.push({recordTime(*heads[head.input]), head.input});
    const TimeNs t = recordTime(record);
    if (recent[t].insert(recordKey(record)).second) {
      writer->write(record);
      ++summary.records[recordKindName(record)];
    } else {
      ++summary.duplicates;
    }
    while (!recent.empty() && recent.begin()->first < t - window) recent.erase(recent.begin());
    if (++done % step == 0) {
      progress.checkStop();
      progress.report("merge", done, expected);
    }
  }
  progress.checkStop();
  for (const auto& reader : readers) {
    summary.issues.insert(summary.issues.end(), reader->issues().begin(), reader->issues().end());
  }
  writer->finish(manifest);
  progress.report("merge", done, done);
  return summary;
}

}  // namespace lookboth
