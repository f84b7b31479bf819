#include "lookboth/pipeline/full_pipeline.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <utility>

#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/detect/detect_dataset.h"
#include "lookboth/registration/site_frame.h"
#include "lookboth/vo/run.h"
#include "overlapped_steps.h"

namespace lookboth {

std::string FullPipelineOptions::check() const {
  if (dataset.empty()) return "'dataset': required";
  if (out.empty()) return "'out': required";
  if (mode == TrajectoryMode::kMetric && trajectory_file.empty() && trajectory_label == "vo")
    return "'trajectory': the metric mode needs a metric trajectory, not 'vo'";
  if (threads < 0) return "'threads': must be >= 0";
  if (!update_record.empty()) return update_check.check();
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
    const TimeNs t = recordTime(*record);
    contents.first = n == 0 ? t : std::min(contents.first, t);
    contents.last = n == 0 ? t : std::max(contents.last, t);
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

namespace {

/// Where a step's results go, as its line says it: the dataset, or the
/// scratch copy (`out`).
std::string writtenTo(const FullPipelineOptions& options, const std::filesystem::path& out) {
  return out.empty() ? options.dataset.string() : "a temporary copy";
}

/// The detection step 1 runs (its options), or nullopt when it is skipped.
std::optional<DetectOptions> detectionFor(const FullPipelineOptions& options,
                                          const std::vector<ConfigLayer>& layers,
                                          const DatasetContents& contents,
                                          const std::filesystem::path& out) {
  const bool need_markers = contents.camera_frames > 0 && contents.markers == 0;
  const bool need_blobs = contents.fisheye_frames > 0 && contents.blob_records == 0;
  if (!options.auto_detect || !(need_markers || need_blobs)) return std::nullopt;
  DetectOptions detect;
  detect.dataset = options.dataset;
  detect.out = out;
  detect.on_issue = options.on_issue;
  detect.threads = options.threads;
  detect.markers = need_markers;
  detect.blobs = need_blobs;
  detect.config = detectConfigFrom(layers);
  return detect;
}

/// "detect: 120 marker detections, 300 fisheye frames with blobs added to ...".
std::string detectLine(const DetectSummary& summary, const std::string& where) {
  std::int64_t markers = 0;
  std::int64_t blobs = 0;
  for (const auto& camera : summary.cameras)
    (camera.fisheye ? blobs : markers) += camera.detections;
  return "detect: " + std::to_string(markers) + " marker detections, " + std::to_string(blobs) +
         " fisheye frames with blobs added to " + where;
}

}  // namespace

StepOutcome runDetectStep(const FullPipelineOptions& options,
                          const std::vector<ConfigLayer>& layers, const DatasetContents& contents,
                          const ProgressReporter& progress, const std::filesystem::path& out) {
  StepOutcome outcome;
  if (const std::optional<DetectOptions> detect = detectionFor(options, layers, contents, out)) {
    outcome.ran = true;
    outcome.summary = detectLine(detectDataset(*detect, progress), writtenTo(options, out));
  } else {
    outcome.summary = "detect: skipped (" +
                      std::string(contents.camera_frames + contents.fisheye_frames == 0
                                      ? "no frames: detections-only dataset"
                                      : (options.auto_detect ? "detections present" : "disabled")) +
                      ")";
  }
  return outcome;
}

namespace {

/// Whether step 2 runs `lookboth odometry`; throws lookboth::Error when it is
/// needed but cannot run.
bool odometryWanted(const FullPipelineOptions& options, const DatasetContents& contents) {
  const std::string vo_label = options.trajectory_label.empty() ? "vo" : options.trajectory_label;
  if (options.mode != TrajectoryMode::kVisual || !options.trajectory_file.empty() ||
      contents.hasTrajectory(vo_label))
    return false;
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
  return true;
}

/// odometryWanted without its errors: false when the odometry cannot run
/// (its step says why).
bool odometryWouldRun(const FullPipelineOptions& options, const DatasetContents& contents) {
  try {
    return odometryWanted(options, contents);
  } catch (const Error&) {
    return false;
  }
}

vo::OdometryRunOptions odometryFor(const FullPipelineOptions& options,
                                   const std::vector<ConfigLayer>& layers,
                                   const std::filesystem::path& out) {
  vo::OdometryRunOptions odometry;
  odometry.dataset = options.dataset;
  odometry.odometry = vo::odometryOptionsFrom(layers);
  odometry.write_dataset = true;  // adds the trajectory to the dataset (augmentDataset)
  odometry.out = out;
  odometry.on_issue = options.on_issue;
  return odometry;
}

/// "odometry: 360 poses added as trajectory 'vo' to ... (2 loop closures)";
/// throws when the odometry tracked nothing.
std::string odometryLine(const vo::OdometryRunSummary& summary, std::int64_t written,
                         const std::string& where) {
  return "odometry: " + std::to_string(written) + " poses added as trajectory '" +
         std::string(vo::kVoTrajectoryLabel) + "' to " + where + " (" +
         std::to_string(summary.result.statistics.loop_closures) + " loop closures)";
}

}  // namespace

StepOutcome runOdometryStep(const FullPipelineOptions& options,
                            const std::vector<ConfigLayer>& layers, const DatasetContents& contents,
                            const ProgressReporter& progress, const std::filesystem::path& out) {
  StepOutcome outcome;
  if (odometryWanted(options, contents)) {
    const vo::OdometryRunSummary summary =
        vo::runOdometry(odometryFor(options, layers, out), progress);
    if (summary.result.trajectory.empty())
      throw Error(options.dataset.string() + ": the visual odometry tracked no frame");
    outcome.ran = true;
    outcome.summary = odometryLine(summary, summary.records_written, writtenTo(options, out));
  } else {
    outcome.summary = "odometry: skipped (" +
                      std::string(options.mode == TrajectoryMode::kMetric ? "metric trajectory"
                                                                          : "trajectory present") +
                      ")";
  }
  return outcome;
}

namespace {

// The record is an input: an output inside it would change it.
void checkOutsideRecord(const std::filesystem::path& out, const std::filesystem::path& record) {
  if (contains(record, out)) {
    throw Error(ErrorContext{out.string(), 0, "", ""},
                "is inside the record '" + record.string() +
                    "'; the record is an input and is never written to: choose another path");
  }
}

// The run in the frame the configuration asks for (RegistrationConfig::
// world_frame); the step line that says which, and why when it is not the
// floor that was asked for.
std::string expressInConfiguredFrame(RegistrationRun& run, const RegistrationConfig& config) {
  if (config.world_frame != "floor") return "frame: the registration's (the first fisheye pose)";
  std::string why;
  try {
    const FloorFit fit = fitFloor(run.registration);
    if (fit.flatness_rms_m <= config.floor_max_flatness_m) {
      AlignedRegistration aligned = alignRegistrationToFloor(run.registration);
      for (DetectionRay& ray : run.rays) {
        ray.from = fit.floor_from_world * ray.from;
        ray.to = fit.floor_from_world * ray.to;
      }
      run.registration = std::move(aligned.registration);
      return "frame: " + aligned.summary.front();
    }
    why = "the trajectory is " + formatFixed(fit.flatness_rms_m * 1000, 1) +
          " mm RMS from its plane, more than floor_max_flatness_m (" +
          formatFixed(config.floor_max_flatness_m * 1000, 1) + " mm): no floor";
  } catch (const Error& e) {
    why = e.what();
  }
  const std::string line =
      "frame: the registration's (the first fisheye pose), not the floor's: " + why;
  run.registration.notes.push_back(line);
  return line;
}

}  // namespace

struct RegistrationPipeline::State {
  // The configuration's files are read once; every section is read from
  // them here, so that a typo in any fails before any work.
  explicit State(const FullPipelineOptions& options)
      : layers(configurationLayers(options.config_file, options.config_overrides)),
        controller(registrationConfigFrom(layers)) {
    detectConfigFrom(layers);
    vo::odometryOptionsFrom(layers);
  }
  std::vector<ConfigLayer> layers;
  RegistrationController controller;
  DatasetContents contents;
  FullPipelineOptions working;  ///< The options with the trajectory chosen, the dataset read.
  std::optional<ScratchDataset> scratch;
  std::optional<RegistrationSession> session;
  std::optional<Registration> record;      ///< FullPipelineOptions::update_record, read.
  std::optional<FacilityCheck> check;      ///< The update's comparison with the record.
  std::optional<RegistrationRun> written;  ///< What the output step wrote.
  /// The odometry run beside detection (overlapped_steps.h), in the detect
  /// step: the odometry step's line, or its error.
  std::optional<std::string> odometry_alongside;
  std::exception_ptr odometry_error;
};

RegistrationPipeline::RegistrationPipeline(FullPipelineOptions options)
    : options_(std::move(options)) {
  if (const std::string problem = options_.check(); !problem.empty()) throw Error(problem);
  // The configuration first: a typo fails in a second, not after detection.
  state_ = std::make_unique<State>(options_);
  steps_ = {"detect", "odometry"};
  const std::vector<std::string>& stages = state_->controller.config().pipeline;
  for (const std::string& stage : stages) steps_.push_back(stage);
  if (!options_.update_record.empty()) {
    if (std::find(stages.begin(), stages.end(), "joint") == stages.end()) {
      throw Error(ErrorContext{"", 0, "register.pipeline", ""},
                  "--update needs the stage 'joint' in register.pipeline (it holds the "
                  "unchanged cameras at the record)");
    }
    checkOutsideRecord(options_.out, options_.update_record);
    // Its cameras are what the update holds to; its blobs it does not read.
    state_->record = loadRegistration(options_.update_record, {false});
    steps_.push_back("update");
  }
  steps_.push_back("output");
}

RegistrationPipeline::~RegistrationPipeline() = default;
RegistrationPipeline::RegistrationPipeline(RegistrationPipeline&&) noexcept = default;

void RegistrationPipeline::prepare(const ProgressReporter& progress) {
  State& st = *state_;
  st.contents = inspectDataset(options_.dataset, progress);
  st.working = options_;
  if (options_.choose_trajectory && options_.trajectory_file.empty()) {
    const TrajectoryChoice choice = chooseTrajectory(options_.dataset, st.contents);
    st.working.mode = choice.mode;
    st.working.trajectory_label = choice.label;
    lines_.push_back("trajectory: " + choice.reason);
  }
  // Without write-back, detection and odometry write a scratch copy that the stages read.
  if (!options_.write_back) st.scratch.emplace(options_);
  prepared_ = true;
}

StepOutcome RegistrationPipeline::detect(const ProgressReporter& progress) {
  State& st = *state_;
  const std::filesystem::path out = st.scratch ? st.scratch->path : std::filesystem::path();
  if (options_.overlap_steps) {
    std::optional<DetectOptions> detect = detectionFor(st.working, st.layers, st.contents, out);
    if (detect && odometryWouldRun(st.working, st.contents))
      return detectAlongsideOdometry(std::move(*detect), progress);
  }
  const StepOutcome outcome = runDetectStep(st.working, st.layers, st.contents, progress, out);
  if (outcome.ran && st.scratch) st.working.dataset = st.scratch->path;
  return outcome;
}

namespace {

/// Where a camera's results go among detection's, which come per camera in
/// the manifest's order: before the first of a camera listed after it.
size_t manifestPosition(const Manifest& manifest, const std::string& label,
                        const std::vector<std::string>& cameras) {
  std::map<std::string, size_t> rank;
  for (size_t i = 0; i < manifest.cameras.size(); ++i) rank[manifest.cameras[i].label] = i;
  const size_t mine = rank[label];
  size_t k = 0;
  while (k < cameras.size() && rank[cameras[k]] < mine) ++k;
  return k;
}

/// The camera a record is of (detection's records are markers and blobs).
const std::string& recordCamera(const Record& record) {
  if (const auto* b = std::get_if<BlobObservation>(&record)) return b->camera;
  return std::get<MarkerObservation>(record).camera;
}

/// Whether the fisheye's blobs can be searched in the odometry's frames as
/// detection would search them: one fisheye, whose every frame the odometry
/// decodes, and detection reading the dataset for the markers all the same
/// (it tells the dataset's issues).
bool blobsFitBesideOdometry(const DetectOptions& detect, const vo::OdometryRunOptions& odometry,
                            const Manifest& manifest) {
  const auto fisheyes =
      std::count_if(manifest.cameras.begin(), manifest.cameras.end(),
                    [](const CameraSensor& c) { return c.role == SensorRole::kFisheye; });
  return detect.blobs && detect.markers && detect.cameras.empty() && odometry.camera.empty() &&
         fisheyes == 1 && odometry.odometry.max_rate_hz == 0;
}

/// The fisheye's blobs: searched beside the odometry when that search is
/// detection's own (`*beside` true), else searched here, after the odometry.
DetectSummary fisheyeBlobs(DetectOptions detect, BlobsBesideOdometry& blobs,
                           const std::vector<DatasetIssue>& told, std::vector<Record>& found,
                           const ProgressReporter& progress, bool* beside) {
  DetectSummary fisheye;
  *beside = false;
  if (FisheyeBlobSearch* search = blobs.finish()) {
    *beside = true;
    found = search->takeRecords();
    fisheye.cameras.push_back(search->summary());
    fisheye.issues = search->issues();
    for (const DatasetIssue& issue : fisheye.issues)
      if (detect.on_issue) detect.on_issue(issue);
    return fisheye;
  }
  detect.markers = false;
  detect.blobs = true;
  const auto on_issue = std::exchange(detect.on_issue, nullptr);
  found = runDetection(detect, progress, &fisheye);
  // The dataset's own issues were told once already, by the first search.
  std::vector<DatasetIssue> issues;
  for (const DatasetIssue& issue : fisheye.issues) {
    const bool again = std::any_of(told.begin(), told.end(), [&](const DatasetIssue& t) {
      return t.where == issue.where && t.message == issue.message;
    });
    if (again) continue;
    if (on_issue) on_issue(issue);
    issues.push_back(issue);
  }
  fisheye.issues = std::move(issues);
  return fisheye;
}

/// The fisheye's blobs added to detection's results where detection puts
/// them (the manifest's order); whether they were searched in the
/// odometry's frames.
bool addBlobs(const DetectOptions& detect, const Manifest& manifest, BlobsBesideOdometry& blobs,
              std::vector<Record>& records, DetectSummary& summary,
              const ProgressReporter& progress) {
  std::vector<Record> found;
  bool beside = false;
  const DetectSummary fisheye =
      fisheyeBlobs(detect, blobs, summary.issues, found, progress, &beside);
  std::vector<std::string> cameras, record_cameras;
  for (const CameraDetectSummary& c : summary.cameras) cameras.push_back(c.camera);
  for (const Record& r : records) record_cameras.push_back(recordCamera(r));
  for (const CameraDetectSummary& c : fisheye.cameras) {
    const size_t at = manifestPosition(manifest, c.camera, cameras);
    summary.cameras.insert(summary.cameras.begin() + static_cast<std::ptrdiff_t>(at), c);
  }
  if (!fisheye.cameras.empty()) {
    const size_t at = manifestPosition(manifest, fisheye.cameras.front().camera, record_cameras);
    records.insert(records.begin() + static_cast<std::ptrdiff_t>(at),
                   std::make_move_iterator(found.begin()), std::make_move_iterator(found.end()));
  }
  summary.issues.insert(summary.issues.end(), fisheye.issues.begin(), fisheye.issues.end());
  return beside;
}

}  // namespace

StepOutcome RegistrationPipeline::detectAlongsideOdometry(DetectOptions detect,
                                                          const ProgressReporter& progress) {
  State& st = *state_;
  const std::string where = writtenTo(st.working, detect.out);
  // Detection keeps its threads: the odometry's thread takes a share of the
  // cores while it runs, and detection has them all once it is done (the
  // odometry is usually the shorter: one camera against many).
  const auto joint = std::make_shared<JointProgress>(progress);
  vo::OdometryRunOptions odometry = odometryFor(st.working, st.layers, {});
  odometry.limit_opencv_threads = false;  // OpenCV's pool is detection's too
  // The fisheye's blobs searched in the frames the odometry decodes: the
  // blob search then decodes none of its own.
  std::optional<BlobsBesideOdometry> blobs;
  const Manifest manifest = DatasetReader::open(detect.dataset)->manifest();
  if (blobsFitBesideOdometry(detect, odometry, manifest)) {
    blobs.emplace(*manifest.fisheye(), detect.config);
    odometry.tap = blobs->tap();
    detect.blobs = false;
  }
  BackgroundOdometry background(std::move(odometry), joint);  // stopped and joined if we throw
  DetectSummary summary;
  // The markers at least: the blobs go beside the odometry only with them.
  std::vector<Record> records = runDetection(detect, joint->detection(), &summary);
  joint->detectionDone();
  std::optional<vo::OdometryRunSummary> odometry_summary;
  try {
    odometry_summary = background.wait(progress);
    if (odometry_summary->result.trajectory.empty())
      throw Error(st.working.dataset.string() + ": the visual odometry tracked no frame");
  } catch (const StopRequested&) {
    throw;  // the step did not finish: nothing written
  } catch (...) {
    st.odometry_error = std::current_exception();  // the odometry step reports it
  }
  const bool blobs_beside = blobs && addBlobs(detect, manifest, *blobs, records, summary, progress);
  // Both written now that nothing reads the dataset: the detections (to
  // the scratch copy, or in place) whatever became of the odometry, then the
  // trajectory into them.
  writeDetections(detect, std::move(records), summary, progress);
  if (st.scratch) st.working.dataset = st.scratch->path;
  if (odometry_summary && !st.odometry_error) {
    const AugmentSummary written =
        vo::addOdometryTrajectory(st.working.dataset, {}, false,
                                  odometry_summary->result.trajectory, options_.on_issue, progress);
    st.odometry_alongside = odometryLine(*odometry_summary, written.added, where) +
                            ", alongside detection (its time is in detect's" +
                            (blobs_beside ? "; the fisheye's blobs searched in its frames)" : ")");
  }
  StepOutcome outcome;
  outcome.ran = true;
  outcome.summary = detectLine(summary, where);
  return outcome;
}

StepOutcome RegistrationPipeline::odometry(const ProgressReporter& progress) {
  State& st = *state_;
  // Run beside detection, in its step: its outcome, or its error (once: a
  // second try runs the odometry on its own).
  if (st.odometry_error) std::rethrow_exception(std::exchange(st.odometry_error, nullptr));
  if (st.odometry_alongside) {
    StepOutcome outcome;
    outcome.ran = true;
    outcome.summary = *std::exchange(st.odometry_alongside, std::nullopt);
    return outcome;
  }
  // On the contents before detection: detection adds no trajectory. A
  // scratch copy that detection made is extended in place.
  const bool in_scratch = st.scratch && st.working.dataset == st.scratch->path;
  const std::filesystem::path out =
      st.scratch && !in_scratch ? st.scratch->path : std::filesystem::path();
  StepOutcome outcome = runOdometryStep(st.working, st.layers, st.contents, progress, out);
  if (outcome.ran && in_scratch) {
    // Extended in place, the scratch copy is still a temporary copy.
    const std::string path = st.scratch->path.string();
    outcome.summary.replace(outcome.summary.find(path), path.size(), "a temporary copy");
  }
  if (outcome.ran && st.scratch) st.working.dataset = st.scratch->path;
  return outcome;
}

StepOutcome RegistrationPipeline::stage(const ProgressReporter& progress) {
  State& st = *state_;
  if (!st.session) {
    RegisterOptions register_options;
    register_options.dataset = st.working.dataset;
    register_options.on_issue = options_.on_issue;
    register_options.mode = st.working.mode;
    register_options.trajectory_label = st.working.trajectory_label;
    register_options.trajectory_file = st.working.trajectory_file;
    st.session.emplace(st.controller.prepare(loadRegistrationInput(register_options, progress)));
  }
  st.session->runNext(progress);
  StepOutcome outcome;
  outcome.ran = true;
  outcome.summary = steps_[next_] + ": done";
  return outcome;
}

StepOutcome RegistrationPipeline::update(const ProgressReporter& progress) {
  State& st = *state_;
  st.check = st.session->updateRecord(*st.record, options_.update_check, progress);
  const FacilityCheck& c = *st.check;
  StepOutcome outcome;
  outcome.ran = true;
  outcome.summary = "update: against " + options_.update_record.string() + ": " +
                    std::to_string(c.moved) + " moved and " + std::to_string(c.added) +
                    " new registered again, " + std::to_string(c.unchanged) +
                    " unchanged held at the record, " + std::to_string(c.not_seen) +
                    " not seen kept from it";
  return outcome;
}

StepOutcome RegistrationPipeline::output(const ProgressReporter& progress) {
  progress.checkStop();
  RegistrationRun run = currentRun();
  // An updated record stays in the record's frame.
  if (!state_->record) lines_.push_back(expressInConfiguredFrame(run, state_->controller.config()));
  writeRegistrationOutput(run, options_.out, options_.overwrite);
  state_->written = run;
  StepOutcome outcome;
  outcome.ran = true;
  outcome.summary = "register: " + std::to_string(run.registration.registeredCount()) + " of " +
                    std::to_string(run.registration.cameras.size()) +
                    " cameras registered, written to " + options_.out.string();
  return outcome;
}

StepOutcome RegistrationPipeline::runNext(const ProgressReporter& progress) {
  if (finished()) throw Error("the pipeline has run every step");
  if (!prepared_) prepare(progress);
  const std::string& name = steps_[next_];
  const auto started = std::chrono::steady_clock::now();
  StepOutcome outcome;
  if (next_ == 0) {
    outcome = detect(progress);
  } else if (next_ == 1) {
    outcome = odometry(progress);
  } else if (next_ + 1 == steps_.size()) {
    outcome = output(progress);
  } else if (state_->record && next_ + 2 == steps_.size()) {
    outcome = update(progress);
  } else {
    outcome = stage(progress);
  }
  // The stages' lines are the summary's business; detection, odometry and
  // the output say what they did or why they were skipped.
  if (name == "detect" || name == "odometry" || next_ + 1 == steps_.size() ||
      (state_->record && next_ + 2 == steps_.size())) {
    lines_.push_back(outcome.summary);
  }
  times_.push_back(
      {name, std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(),
       outcome.ran});
  ++next_;
  return outcome;
}

const RegistrationSession* RegistrationPipeline::session() const {
  return state_->session ? &*state_->session : nullptr;
}

FacilityCheck RegistrationPipeline::updateRecord(const std::filesystem::path& record,
                                                 const FacilityCheckOptions& options,
                                                 const std::filesystem::path& out,
                                                 const ProgressReporter& progress) {
  if (!finished()) throw Error("update: the pipeline has not run every step");
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  checkOutsideRecord(out, record);
  checkRegistrationOutput(out, false, {record, dataset()});
  const FacilityCheck check =
      state_->session->updateRecord(loadRegistration(record, {false}), options, progress);
  RegistrationRun run = currentRun();
  writeRegistrationOutput(run, out, false);
  state_->written = std::move(run);
  state_->check = check;
  return check;
}

const RegistrationRun* RegistrationPipeline::written() const {
  return state_->written ? &*state_->written : nullptr;
}

const std::filesystem::path& RegistrationPipeline::dataset() const {
  return state_->working.dataset.empty() ? options_.dataset : state_->working.dataset;
}

FullPipelineResult RegistrationPipeline::run(const ProgressReporter& progress) {
  while (!finished()) runNext(progress);
  FullPipelineResult result;
  result.steps = lines_;
  result.run = *state_->written;
  result.check = state_->check;
  result.times = times_;
  result.drive_seconds = driveSeconds();
  return result;
}

RegistrationRun RegistrationPipeline::currentRun() const {
  RegistrationRun run = state_->session->current();
  RegistrationStatistics& statistics = run.registration.statistics;
  for (const StepTime& step : times_) {
    if (step.ran && (step.step == "detect" || step.step == "odometry")) {
      statistics.seconds_per_step[step.step] = step.seconds;
    }
  }
  statistics.drive_seconds = driveSeconds();
  return run;
}

double RegistrationPipeline::driveSeconds() const {
  return static_cast<double>(state_->contents.last - state_->contents.first) * 1e-9;
}

std::string describeTimes(const FullPipelineResult& result) {
  // The stages are quick next to detection and odometry: one figure for them.
  double total = 0, stages = 0;
  std::string text = "run time:";
  for (const StepTime& step : result.times) {
    total += step.seconds;
    const bool stage = step.step != "detect" && step.step != "odometry" && step.step != "output";
    if (stage) {
      stages += step.seconds;
      continue;
    }
    if (step.step == "output") text += " stages " + formatFixed(stages, 1) + " s,";
    text += " " + step.step + " " + formatFixed(step.seconds, 1) + " s" +
            (step.step == "output" ? ";" : ",");
  }
  text += " " + formatFixed(total, 1) + " s in all";
  if (result.drive_seconds > 0) {
    text += ", " + formatFixed(total / result.drive_seconds, 2) + "x the drive (" +
            formatFixed(result.drive_seconds, 1) + " s)";
  }
  return text;
}

FullPipelineResult runFullPipeline(const FullPipelineOptions& options,
                                   const ProgressReporter& progress) {
  return RegistrationPipeline(options).run(progress);
}

}  // namespace lookboth
