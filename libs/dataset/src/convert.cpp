#include "lookboth/dataset/convert.h"

#include <algorithm>
#include <iterator>
#include <map>
#include <memory>
#include <set>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/geometry/tum.h"
#include "video_frames.h"

namespace lookboth {

namespace fs = std::filesystem;

const char* dataKindName(DataKind kind) {
  switch (kind) {
    case DataKind::kAuto:
      return "auto";
    case DataKind::kRawlog:
      return "rawlog";
    case DataKind::kFolder:
      return "folder";
    case DataKind::kBag:
      return "bag";
    case DataKind::kTum:
      return "tum";
  }
  return "?";
}

std::optional<DataKind> parseDataKind(const std::string& name) {
  for (DataKind kind :
       {DataKind::kAuto, DataKind::kRawlog, DataKind::kFolder, DataKind::kBag, DataKind::kTum}) {
    if (name == dataKindName(kind)) return kind;
  }
  return std::nullopt;
}

DataKind detectDataKind(const fs::path& path) {
  const std::string ext = path.extension().string();
  // ROS 1 (.bag) and ROS 2 bags: one .mcap or .db3 file, or a rosbag2 folder.
  if (ext == ".bag" || ext == ".mcap" || ext == ".db3") return DataKind::kBag;
  std::error_code ec;
  if (path.filename() == "metadata.yaml" || fs::exists(path / "metadata.yaml", ec))
    return DataKind::kBag;
  if (ext == ".tum" || ext == ".txt") return DataKind::kTum;
  return detectDatasetKind(path) == DatasetKind::kRawlog ? DataKind::kRawlog : DataKind::kFolder;
}

std::string ConvertOptions::check() const {
  if (from.empty()) return "'--from': required";
  if (to.empty()) return "'--to': required";
  for (const TrajectoryInput& t : add_trajectories) {
    if (t.info.label.empty()) return "'--trajectory': a label is needed for " + t.file.string();
  }
  std::set<std::string> video_labels;
  for (const VideoInput& v : videos) {
    if (v.label.empty() || v.file.empty()) return "'--video': expected LABEL=FILE";
    if (!video_labels.insert(v.label).second)
      return "'--video': two videos for camera '" + v.label + "' (join them first)";
    if (v.times.empty() && !v.start)
      return "'--video': the frame times of " + v.file.string() +
             " are unknown: add :times=FILE.csv (timestamp_ns per frame) or :start=NS (the first "
             "frame's time; the container gives the others)";
    if (!v.times.empty() && v.start)
      return "'--video': " + v.file.string() + ": give :times or :start, not both";
  }
  // However the paths are spelled: the same file, a link to it, "ds/" for "ds".
  std::vector<fs::path> inputs = datasetPaths(from);
  for (const TrajectoryInput& t : add_trajectories) inputs.push_back(t.file);
  for (const VideoInput& v : videos) {
    for (const fs::path& file : {v.file, v.times, v.calibration})
      if (!file.empty()) inputs.push_back(file);
  }
  for (const fs::path& output : datasetPaths(to)) {
    for (const fs::path& input : inputs) {
      if (sameFile(output, input) || contains(output, input)) {
        return "'--to': " + to.string() + " would overwrite the input '" + input.string() +
               "' (inputs are never written to)";
      }
    }
  }
  return "";
}

std::int64_t ConvertSummary::total() const {
  std::int64_t n = 0;
  for (const auto& [kind, count] : records) n += count;
  return n;
}

namespace {

DatasetKind asDatasetKind(DataKind kind, const fs::path& path) {
  if (kind == DataKind::kRawlog) return DatasetKind::kRawlog;
  if (kind == DataKind::kFolder) return DatasetKind::kFolder;
  throw Error({path.string(), 0, "", ""},
              std::string("expected a dataset here, not a ") + dataKindName(kind));
}

void addTrajectories(const ConvertOptions& options, Manifest& manifest, DatasetWriter& writer,
                     ConvertSummary& summary, const ProgressReporter& progress) {
  for (const TrajectoryInput& input : options.add_trajectories) {
    progress.checkStop();
    if (manifest.findTrajectory(input.info.label)) {
      throw Error({input.file.string(), 0, "", ""},
                  "the dataset already has a trajectory labelled '" + input.info.label + "'");
    }
    const Trajectory trajectory = readTumFile(input.file);
    for (const StampedPose& sample : trajectory.samples()) {
      writer.write(PoseSample{sample.t, input.info.label, sample.world_from_body});
      ++summary.records["pose"];
    }
    manifest.trajectories.push_back(input.info);
  }
}

/// The manifest of options.cameras alone (convert --cameras): those cameras,
/// their ground truth, no trajectories. Throws for a label it does not list.
void keepCameras(const ConvertOptions& options, Manifest* manifest) {
  std::vector<CameraSensor> kept;
  for (const std::string& label : options.cameras) {
    const CameraSensor* camera = manifest->findCamera(label);
    if (!camera) {
      std::string labels;
      for (const CameraSensor& c : manifest->cameras)
        labels += (labels.empty() ? "" : ", ") + c.label;
      throw Error({options.from.string(), 0, "--cameras", label},
                  "no such camera in the dataset (cameras: " + labels + ")");
    }
    kept.push_back(*camera);
  }
  std::stable_sort(kept.begin(), kept.end(), [](const CameraSensor& a, const CameraSensor& b) {
    return a.role == SensorRole::kFisheye && b.role != SensorRole::kFisheye;
  });
  manifest->cameras = kept;
  manifest->trajectories.clear();
  GroundTruth& truth = manifest->ground_truth;
  auto dropOthers = [&](auto& by_label) {
    for (auto it = by_label.begin(); it != by_label.end();)
      it = manifest->findCamera(it->first) ? std::next(it) : by_label.erase(it);
  };
  dropOthers(truth.world_from_camera);
  dropOthers(truth.clock_offset);
  dropOthers(truth.hidden_from_fisheye);
  // The spans stay with their camera when the fisheye goes: an edge node's
  // part of a recording merges back into the whole with them.
  if (!manifest->fisheye()) truth.fisheye_from_marker.reset();
}

/// Whether a record belongs to one of the manifest's cameras (poses do not).
bool ofCameras(const Record& record, const Manifest& manifest) {
  if (const auto* frame = std::get_if<ImageFrame>(&record))
    return manifest.findCamera(frame->sensor) != nullptr;
  if (const auto* marker = std::get_if<MarkerObservation>(&record))
    return manifest.findCamera(marker->camera) != nullptr;
  if (const auto* blobs = std::get_if<BlobObservation>(&record))
    return manifest.findCamera(blobs->camera) != nullptr;
  return false;
}

/// The frames of the `--video` inputs, written in time order among the
/// input's records (writeUntil before each record).
class VideoFrames {
 public:
  VideoFrames(const ConvertOptions& options, Manifest& manifest, ConvertSummary& summary)
      : summary_(summary), on_issue_(options.on_issue) {
    for (const VideoInput& input : options.videos) {
      addCamera(input, manifest);
      internal::VideoTiming timing{input.times, input.start, ""};
      auto sink = [this](bool note) {
        return [this, note](const std::string& where, const std::string& message) {
          DatasetIssue issue{where, message, note};
          if (on_issue_) on_issue_(issue);
          summary_.issues.push_back(std::move(issue));
        };
      };
      sources_.push_back(std::make_unique<internal::VideoFrameSource>(
          input.file, input.label, timing, sink(false), sink(true)));
      labels_.insert(input.label);
    }
    heads_.resize(sources_.size());
    for (size_t i = 0; i < sources_.size(); ++i) heads_[i] = sources_[i]->next();
  }

  /// A frame of the input that a video replaces (it is not written).
  bool replaces(const Record& record) {
    const auto* frame = std::get_if<ImageFrame>(&record);
    if (!frame || !labels_.count(frame->sensor)) return false;
    ++replaced_[frame->sensor];
    return true;
  }

  /// Writes the videos' frames up to `t` (all of them without one).
  void writeUntil(std::optional<TimeNs> t, DatasetWriter& writer) {
    for (size_t i = 0; i < sources_.size(); ++i) {
      while (heads_[i] && (!t || heads_[i]->t <= *t)) {
        writer.write(*heads_[i]);
        ++summary_.records["image"];
        heads_[i] = sources_[i]->next();
      }
    }
  }

  /// Says how many of the input's frames the videos replaced.
  void reportReplaced(const fs::path& from) {
    for (const auto& [label, count] : replaced_) {
      DatasetIssue issue{from.string(),
                         "camera '" + label + "': its " + std::to_string(count) +
                             " frames in the input were replaced by the video",
                         true};
      if (on_issue_) on_issue_(issue);
      summary_.issues.push_back(std::move(issue));
    }
  }

 private:
  static void addCamera(const VideoInput& input, Manifest& manifest) {
    if (manifest.findCamera(input.label)) {
      if (!input.calibration.empty()) {
        throw Error({input.calibration.string(), 0, "--calibration", input.label},
                    "the input already has camera '" + input.label +
                        "' with its calibration: leave --calibration out");
      }
      return;
    }
    if (input.calibration.empty()) {
      throw Error({input.file.string(), 0, "--video", input.label},
                  "the input has no camera '" + input.label +
                      "': give its calibration with --calibration " + input.label + "=FILE");
    }
    CameraSensor sensor;
    sensor.label = input.label;
    sensor.role = input.label == "fisheye" && !manifest.fisheye() ? SensorRole::kFisheye
                                                                  : SensorRole::kEnvCamera;
    sensor.camera = loadCamera(input.calibration);
    manifest.cameras.push_back(sensor);
  }

  ConvertSummary& summary_;
  std::function<void(const DatasetIssue&)> on_issue_;
  std::vector<std::unique_ptr<internal::VideoFrameSource>> sources_;
  std::vector<std::optional<ImageFrame>> heads_;
  std::set<std::string> labels_;
  std::map<std::string, std::int64_t> replaced_;
};

ConvertSummary datasetToDataset(const ConvertOptions& options, DataKind from_kind, DataKind to_kind,
                                const ProgressReporter& progress) {
  ConvertSummary summary;
  DatasetReadOptions read_options;
  read_options.strict = options.strict;
  read_options.on_issue = options.on_issue;
  auto reader = DatasetReader::open(options.from, read_options);
  (void)asDatasetKind(from_kind, options.from);
  Manifest manifest = reader->manifest();
  if (!options.cameras.empty()) keepCameras(options, &manifest);
  VideoFrames videos(options, manifest, summary);
  manifest.name =
      to_kind == DataKind::kRawlog ? options.to.stem().string() : options.to.filename().string();
  manifest.rawlog_entries = -1;
  DatasetWriteOptions write_options;
  write_options.overwrite = options.overwrite;
  auto writer = DatasetWriter::create(options.to, asDatasetKind(to_kind, options.to), manifest,
                                      write_options);
  const std::int64_t expected = reader->expectedCount();
  std::int64_t done = 0;
  while (auto record = reader->next()) {
    if ((done & 63) == 0) {
      progress.checkStop();
      progress.report("convert", done, expected > 0 ? expected : 0);
    }
    ++done;
    if (!options.cameras.empty() && !ofCameras(*record, manifest)) continue;
    if (videos.replaces(*record)) continue;
    videos.writeUntil(recordTime(*record), *writer);
    writer->write(*record);
    ++summary.records[recordKindName(*record)];
  }
  videos.writeUntil(std::nullopt, *writer);
  addTrajectories(options, manifest, *writer, summary, progress);
  progress.checkStop();
  writer->finish(manifest);
  progress.report("convert", done, done > 0 ? done : 1);
  summary.issues.insert(summary.issues.begin(), reader->issues().begin(), reader->issues().end());
  videos.reportReplaced(options.from);
  return summary;
}

ConvertSummary datasetToTum(const ConvertOptions& options, const ProgressReporter& progress) {
  ConvertSummary summary;
  DatasetReadOptions read_options;
  read_options.strict = options.strict;
  read_options.check_images = false;
  read_options.on_issue = options.on_issue;
  auto reader = DatasetReader::open(options.from, read_options);
  std::string label = options.trajectory_label;
  const Manifest& manifest = reader->manifest();
  if (label.empty()) {
    if (manifest.findTrajectory("odometry")) {
      label = "odometry";
    } else if (manifest.trajectories.size() == 1) {
      label = manifest.trajectories.front().label;
    } else {
      std::string labels;
      for (const auto& t : manifest.trajectories) labels += " " + t.label;
      throw Error({options.from.string(), 0, "", ""},
                  manifest.trajectories.empty()
                      ? "holds no trajectory"
                      : "holds several trajectories; choose one with --label:" + labels);
    }
  }
  if (!manifest.findTrajectory(label)) {
    throw Error({options.from.string(), 0, "trajectories", ""},
                "no trajectory labelled '" + label + "'");
  }
  if (fs::exists(options.to) && !options.overwrite) {
    throw Error({options.to.string(), 0, "", ""}, "already exists (use --overwrite to replace it)");
  }
  AtomicOutputFile out(options.to);
  out.stream() << "# timestamp[s] tx ty tz qx qy qz qw (world_from_body) trajectory '" << label
               << "' of " << options.from.filename().string() << "\n";
  std::int64_t done = 0;
  TimeNs last = 0;
  while (auto record = reader->next()) {
    if ((++done & 255) == 0) {
      progress.checkStop();
      progress.report("export trajectory", done,
                      reader->expectedCount() > 0 ? reader->expectedCount() : 0);
    }
    const auto* sample = std::get_if<PoseSample>(&*record);
    if (!sample || sample->label != label) continue;
    if (summary.records["pose"] > 0 && sample->t <= last) {
      throw Error({options.from.string(), 0, "", label},
                  "trajectory samples are not in time order at " + formatSeconds(sample->t) +
                      " s; a TUM file needs increasing timestamps");
    }
    out.stream() << formatTumRow({sample->t, sample->world_from_body}) << '\n';
    last = sample->t;
    ++summary.records["pose"];
  }
  out.commit();
  summary.issues = reader->issues();
  return summary;
}

ConvertSummary tumToDataset(const ConvertOptions& options, DataKind to_kind,
                            const ProgressReporter& progress) {
  ConvertSummary summary;
  Manifest manifest;
  manifest.name =
      to_kind == DataKind::kRawlog ? options.to.stem().string() : options.to.filename().string();
  DatasetWriteOptions write_options;
  write_options.overwrite = options.overwrite;
  ConvertOptions with_input = options;
  TrajectoryInput input;
  input.file = options.from;
  input.info.label = options.trajectory_label.empty() ? "odometry" : options.trajectory_label;
  input.info.metric = options.trajectory_metric;
  input.info.description = "imported from " + options.from.filename().string();
  with_input.add_trajectories.insert(with_input.add_trajectories.begin(), input);
  auto writer = DatasetWriter::create(options.to, asDatasetKind(to_kind, options.to), manifest,
                                      write_options);
  addTrajectories(with_input, manifest, *writer, summary, progress);
  writer->finish(manifest);
  return summary;
}

}  // namespace

std::pair<DataKind, DataKind> resolveDataKinds(const ConvertOptions& options) {
  const DataKind from_kind =
      options.from_kind == DataKind::kAuto ? detectDataKind(options.from) : options.from_kind;
  DataKind to_kind = options.to_kind;
  if (to_kind == DataKind::kAuto) {
    to_kind = options.to.extension() == ".rawlog" ? DataKind::kRawlog : detectDataKind(options.to);
  }
  return {from_kind, to_kind};
}

ConvertSummary convertData(const ConvertOptions& options, const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  const auto [from_kind, to_kind] = resolveDataKinds(options);
  if (!fs::exists(options.from))
    throw Error({options.from.string(), 0, "", ""}, "no such file or folder");
  if (from_kind == DataKind::kBag) {
    throw Error({options.from.string(), 0, "", ""},
                "ROS bags are imported with importRosbag (rosbag_import.h)");
  }
  if (to_kind == DataKind::kBag)
    throw Error({options.to.string(), 0, "", ""}, "writing ROS bags is not supported");
  if (from_kind == DataKind::kTum) {
    if (to_kind == DataKind::kTum) throw Error("TUM to TUM: nothing to convert");
    return tumToDataset(options, to_kind, progress);
  }
  if (to_kind == DataKind::kTum) return datasetToTum(options, progress);
  return datasetToDataset(options, from_kind, to_kind, progress);
}

}  // namespace lookboth
