#include "lookboth/pipeline/full_pipeline.h"

#include <unistd.h>

#include <algorithm>

#include "lookboth/core/error.h"
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
  return std::any_of(trajectories.begin(), trajectories.end(),
                     [&](const TrajectoryInfo& info) { return info.label == label; });
}

namespace {

constexpr const char* kGroundTruthLabel = "ground_truth";

/// "odometry (metric), vo (up to scale)" or "none".
std::string describeTrajectories(const DatasetContents& contents) {
  std::string list;
  for (const TrajectoryInfo& info : contents.trajectories) {
    list +=
        (list.empty() ? "" : ", ") + info.label + (info.metric ? " (metric)" : " (up to scale)");
  }
  return list.empty() ? "none" : list;
}

std::vector<std::string> labelsWhere(const DatasetContents& contents, bool metric) {
  std::vector<std::string> labels;
  for (const TrajectoryInfo& info : contents.trajectories) {
    if (info.metric == metric && info.label != kGroundTruthLabel) labels.push_back(info.label);
  }
  return labels;
}

}  // namespace

TrajectoryChoice chooseTrajectory(const std::filesystem::path& dataset,
                                  const DatasetContents& contents) {
  const std::string vo = vo::kVoTrajectoryLabel;
  const std::string other = "; choose another with --trajectory or --trajectory-label";
  if (contents.hasTrajectory(vo))
    return {TrajectoryMode::kVisual, vo, "its visual odometry '" + vo + "', up to scale" + other};
  const std::vector<std::string> unscaled = labelsWhere(contents, false);
  if (unscaled.size() > 1) {
    throw Error(dataset.string() + ": several trajectories up to scale (" +
                describeTrajectories(contents) +
                "): choose one with --trajectory-label <label> (--trajectory visual)");
  }
  if (unscaled.size() == 1) {
    return {TrajectoryMode::kVisual, unscaled.front(),
            "its only trajectory up to scale, '" + unscaled.front() +
                "' (visual mode: the scale is estimated)" + other};
  }
  if (contents.fisheye_frames > 0) {
    return {TrajectoryMode::kVisual, vo,
            "visual odometry on its fisheye frames, as '" + vo + "'" + other};
  }
  const std::vector<std::string> metric = labelsWhere(contents, true);
  if (contents.hasTrajectory("odometry") || metric.size() == 1) {
    const std::string label = contents.hasTrajectory("odometry") ? "odometry" : metric.front();
    return {
        TrajectoryMode::kMetric, label,
        "its metric trajectory '" + label + "' (no visual odometry, no fisheye frames)" + other};
  }
  const std::string none = dataset.string() +
                           ": no trajectory to register with (the dataset's trajectories: " +
                           describeTrajectories(contents) + ")";
  if (!metric.empty())
    throw Error(none + ": choose one with --trajectory metric --trajectory-label <label>");
  throw Error(none +
              "; add one (`lookboth convert --from <dataset> --to <new dataset> --trajectory "
              "x.tum=label:metric`) or give --trajectory-file");
}

DatasetContents inspectDataset(const std::filesystem::path& dataset,
                               const ProgressReporter& progress) {
  DatasetReadOptions read_options;
  read_options.check_images = false;
  auto reader = DatasetReader::open(dataset, read_options);
  const Manifest& manifest = reader->manifest();
  const CameraSensor* fisheye = manifest.fisheye();
  DatasetContents contents;
  contents.trajectories = manifest.trajectories;
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
    detect.config = detectConfigFor(options.config_file);
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
                  "' and no fisheye frames to run `lookboth odometry` on (the dataset's "
                  "trajectories: " +
                  describeTrajectories(contents) +
                  "); leave out --trajectory to let register choose, or name one: "
                  "--trajectory-label <label> for one up to scale, --trajectory metric for a "
                  "metric one");
    if (vo_label != vo::kVoTrajectoryLabel)
      throw Error(options.dataset.string() + ": no visual odometry trajectory '" + vo_label +
                  "': `lookboth odometry` writes '" + std::string(vo::kVoTrajectoryLabel) + "'");
    vo::OdometryRunOptions odometry;
    odometry.dataset = options.dataset;
    odometry.odometry = vo::odometryOptionsFor(options.config_file);
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
  FullPipelineOptions working = options;
  if (options.choose_trajectory && options.trajectory_file.empty()) {
    const TrajectoryChoice choice = chooseTrajectory(options.dataset, contents);
    working.mode = choice.mode;
    working.trajectory_label = choice.label;
    result.steps.push_back("trajectory: " + choice.reason);
  }
  // Without write-back, steps 1-2 write a scratch copy that the stages read.
  const std::optional<ScratchDataset> scratch =
      options.write_back ? std::nullopt : std::optional<ScratchDataset>(ScratchDataset(options));
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
  register_options.mode = working.mode;
  register_options.trajectory_label = working.trajectory_label;
  register_options.trajectory_file = working.trajectory_file;
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
