#include "lookboth/calib/full_pipeline.h"

#include <unistd.h>

#include <algorithm>

#include "lookboth/core/error.h"
#include "lookboth/core/paths.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/detect/detect_dataset.h"
#include "lookboth/vo/run.h"

namespace lookboth {

std::string FullPipelineOptions::check() const {
  if (dataset.empty()) return "'dataset': required";
  if (out.empty()) return "'out': required";
  if (mode == TrajectoryMode::kMetric && trajectory_file.empty() && trajectory_label == "vo")
    return "'trajectory': the metric mode needs a metric trajectory, not 'vo'";
  if (threads < 0) return "'threads': must be >= 0";
  return "";
}

bool DatasetContents::hasTrajectory(const std::string& label) const {
  return std::find(trajectories.begin(), trajectories.end(), label) != trajectories.end();
}

DatasetContents inspectDataset(const std::filesystem::path& dataset,
                               const ProgressReporter& progress) {
  DatasetReadOptions read_options;
  read_options.check_images = false;
  auto reader = DatasetReader::open(dataset, read_options);
  const Manifest& manifest = reader->manifest();
  const CameraSensor* fisheye = manifest.fisheye();
  DatasetContents contents;
  for (const auto& info : manifest.trajectories) contents.trajectories.push_back(info.label);
  std::int64_t n = 0;
  const std::int64_t expected = std::max<std::int64_t>(reader->expectedCount(), 0);
  while (auto record = reader->next()) {
    if (const auto* frame = std::get_if<ImageFrame>(&*record)) {
      if (fisheye && frame->sensor == fisheye->label) {
        ++contents.fisheye_frames;
      } else {
        ++contents.camera_frames;
      }
    } else if (std::holds_alternative<MarkerObservation>(*record)) {
      ++contents.markers;
    } else if (std::holds_alternative<BlobObservation>(*record)) {
      ++contents.blob_records;
    }
    if (++n % 1024 == 0) {
      progress.checkStop();
      progress.report("inspect", n, expected);
    }
  }
  return contents;
}

namespace {

std::filesystem::path defaultConfigFile() { return shareDirectory() / "config" / "default.yaml"; }

/// A hidden dataset beside the registration output, in the input's layout,
/// removed (with its manifest and images) when the run ends however it ends.
struct ScratchDataset {
  explicit ScratchDataset(const FullPipelineOptions& options) {
    namespace fs = std::filesystem;
    const fs::path out = fs::absolute(options.out).lexically_normal();
    // No dot after the leading one: a folder dataset's name has no extension.
    const std::string stem =
        "." + out.filename().string() + "-dataset-tmp-" + std::to_string(::getpid());
    const bool rawlog = detectDatasetKind(options.dataset) == DatasetKind::kRawlog;
    path = out.parent_path() / (rawlog ? stem + ".rawlog" : stem);
    parts = {path};
    if (rawlog) parts = {manifestPathFor(path), path, imagesDirectoryFor(path)};
  }
  ScratchDataset(ScratchDataset&& other) noexcept
      : path(std::move(other.path)), parts(std::move(other.parts)) {
    other.parts.clear();
  }
  ScratchDataset(const ScratchDataset&) = delete;
  ScratchDataset& operator=(const ScratchDataset&) = delete;
  ScratchDataset& operator=(ScratchDataset&&) = delete;
  ~ScratchDataset() {
    std::error_code ignored;
    for (const auto& part : parts) std::filesystem::remove_all(part, ignored);
  }
  std::filesystem::path path;
  std::vector<std::filesystem::path> parts;
};

}  // namespace

StepOutcome runDetectStep(const FullPipelineOptions& options, const DatasetContents& contents,
                          const ProgressReporter& progress, const std::filesystem::path& out) {
  StepOutcome outcome;
  const bool need_markers = contents.camera_frames > 0 && contents.markers == 0;
  const bool need_blobs = contents.fisheye_frames > 0 && contents.blob_records == 0;
  if (options.auto_detect && (need_markers || need_blobs)) {
    DetectOptions detect;
    detect.dataset = options.dataset;
    detect.out = out;
    detect.on_issue = options.on_issue;
    detect.threads = options.threads;
    detect.markers = need_markers;
    detect.blobs = need_blobs;
    detect.config =
        options.config_file ? loadDetectConfig(*options.config_file) : defaultDetectConfig();
    const DetectSummary summary = detectDataset(detect, progress);
    std::int64_t markers = 0;
    std::int64_t blobs = 0;
    for (const auto& camera : summary.cameras)
      (camera.fisheye ? blobs : markers) += camera.detections;
    outcome.ran = true;
    outcome.summary = "detect: " + std::to_string(markers) + " marker detections, " +
                      std::to_string(blobs) + " fisheye frames with blobs added to " +
                      (out.empty() ? options.dataset.string() : std::string("a temporary copy"));
  } else {
    outcome.summary = "detect: skipped (" +
                      std::string(contents.camera_frames + contents.fisheye_frames == 0
                                      ? "no frames: detections-only dataset"
                                      : (options.auto_detect ? "detections present" : "disabled")) +
                      ")";
  }
  return outcome;
}

StepOutcome runOdometryStep(const FullPipelineOptions& options, const DatasetContents& contents,
                            const ProgressReporter& progress, const std::filesystem::path& out) {
  StepOutcome outcome;
  const std::string vo_label = options.trajectory_label.empty() ? "vo" : options.trajectory_label;
  if (options.mode == TrajectoryMode::kVisual && options.trajectory_file.empty() &&
      !contents.hasTrajectory(vo_label)) {
    if (!options.auto_odometry)
      throw Error(options.dataset.string() + ": no visual odometry trajectory '" + vo_label +
                  "': run `lookboth odometry` first");
    if (contents.fisheye_frames == 0)
      throw Error(options.dataset.string() + ": no visual odometry trajectory '" + vo_label +
                  "' and no fisheye frames to run `lookboth odometry` on; use a metric "
                  "trajectory (--trajectory metric)");
    if (vo_label != vo::kVoTrajectoryLabel)
      throw Error(options.dataset.string() + ": no visual odometry trajectory '" + vo_label +
                  "': `lookboth odometry` writes '" + std::string(vo::kVoTrajectoryLabel) + "'");
    vo::OdometryRunOptions odometry;
    odometry.dataset = options.dataset;
    odometry.odometry = vo::loadOdometryOptions(defaultConfigFile());
    if (options.config_file)
      odometry.odometry = vo::loadOdometryOptions(*options.config_file, odometry.odometry);
    odometry.write_dataset = true;  // adds the trajectory to the dataset (augmentDataset)
    odometry.out = out;
    odometry.on_issue = options.on_issue;
    const vo::OdometryRunSummary summary = vo::runOdometry(odometry, progress);
    if (summary.result.trajectory.empty())
      throw Error(options.dataset.string() + ": the visual odometry tracked no frame");
    outcome.ran = true;
    outcome.summary = "odometry: " + std::to_string(summary.records_written) +
                      " poses added as trajectory '" + vo_label + "' to " +
                      (out.empty() ? options.dataset.string() : std::string("a temporary copy")) +
                      " (" + std::to_string(summary.result.statistics.loop_closures) +
                      " loop closures)";
  } else {
    outcome.summary = "odometry: skipped (" +
                      std::string(options.mode == TrajectoryMode::kMetric ? "metric trajectory"
                                                                          : "trajectory present") +
                      ")";
  }
  return outcome;
}

FullPipelineResult runFullPipeline(const FullPipelineOptions& options,
                                   const ProgressReporter& progress) {
  if (const std::string problem = options.check(); !problem.empty()) throw Error(problem);
  FullPipelineResult result;
  // Check the registration configuration first: a typo fails in a second, not after detection.
  RegistrationController controller(loadRegistrationConfig(options.config_file));

  DatasetContents contents = inspectDataset(options.dataset, progress);
  // Without write-back, steps 1-2 write a scratch copy that the stages read.
  const std::optional<ScratchDataset> scratch =
      options.write_back ? std::nullopt : std::optional<ScratchDataset>(ScratchDataset(options));
  FullPipelineOptions working = options;
  const std::filesystem::path step_out = scratch ? scratch->path : std::filesystem::path();
  // 1. Detection.
  const StepOutcome detected = runDetectStep(working, contents, progress, step_out);
  result.steps.push_back(detected.summary);
  if (detected.ran && scratch) working.dataset = scratch->path;
  // 2. Visual odometry (on the contents before detection: detection adds no trajectory).
  const bool in_scratch = scratch && working.dataset == scratch->path;
  const StepOutcome odometry =
      runOdometryStep(working, contents, progress, in_scratch ? std::filesystem::path() : step_out);
  result.steps.push_back(odometry.summary);
  if (odometry.ran && scratch) working.dataset = scratch->path;

  // 3-4. Registration and its output.
  RegisterOptions register_options;
  register_options.dataset = working.dataset;
  register_options.on_issue = options.on_issue;
  register_options.mode = options.mode;
  register_options.trajectory_label = options.trajectory_label;
  register_options.trajectory_file = options.trajectory_file;
  RegistrationInput input = loadRegistrationInput(register_options, progress);
  result.run = controller.run(std::move(input), progress);
  progress.checkStop();
  writeRegistrationOutput(result.run, options.out, options.overwrite);
  result.steps.push_back("register: " + std::to_string(result.run.registration.registeredCount()) +
                         " of " + std::to_string(result.run.registration.cameras.size()) +
                         " cameras registered, written to " + options.out.string());
  return result;
}

}  // namespace lookboth
