// The registration controller: configuration, input, stages in order, output.
#include "lookboth/pipeline/registration_controller.h"

#include <ceres/version.h>
#include <mrpt/version.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <iomanip>
#include <opencv2/core/version.hpp>
#include <sstream>

#include "lookboth/calib/record_update.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/paths.h"
#include "lookboth/core/temporary_files.h"
#include "lookboth/core/text.h"
#include "lookboth/core/version.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/geometry/tum.h"
#include "lookboth/report/scene.h"

namespace lookboth {
namespace fs = std::filesystem;

// ---- configuration ----

StageConfig RegistrationConfig::stageConfig(const std::string& name) const {
  StageConfig config;
  config.field = "register." + name;
  for (const StageConfig::Layer& layer : layers) {
    StageConfig::Layer stage_layer;
    stage_layer.reader = layer.reader;
    if (layer.node.IsDefined() && layer.node.IsMap()) {
      // (Assigning a missing key's node to a Node throws in yaml-cpp; test first.)
      const YAML::Node section = layer.node[name];
      if (section.IsDefined()) stage_layer.node = section;
    }
    config.layers.push_back(stage_layer);
  }
  return config;
}

namespace {

YAML::Node mergeNodes(const YAML::Node& base, const YAML::Node& over) {
  if (!over.IsDefined() || over.IsNull()) return YAML::Clone(base);
  if (!base.IsDefined() || base.IsNull() || !base.IsMap() || !over.IsMap()) {
    return YAML::Clone(over);
  }
  YAML::Node merged = YAML::Clone(base);
  for (const auto& entry : over) {
    const std::string key = entry.first.as<std::string>();
    merged[key] = mergeNodes(base[key], entry.second);
  }
  return merged;
}

// register.world_frame and register.floor_max_flatness_m of one layer.
void readFrameKeys(const YamlReader& reader, const YAML::Node& section,
                   RegistrationConfig& config) {
  if (const YAML::Node frame = section["world_frame"]; frame) {
    config.world_frame = reader.text(frame, "register.world_frame");
    if (config.world_frame != "floor" && config.world_frame != "registration") {
      throw Error(reader.at(frame, "register.world_frame"),
                  "expected 'floor' or 'registration', not '" + config.world_frame + "'");
    }
  }
  if (const YAML::Node flatness = section["floor_max_flatness_m"]; flatness) {
    config.floor_max_flatness_m = reader.number(flatness, "register.floor_max_flatness_m");
    if (config.floor_max_flatness_m <= 0) {
      throw Error(reader.at(flatness, "register.floor_max_flatness_m"), "must be > 0");
    }
  }
}

}  // namespace

std::string RegistrationConfig::mergedYaml() const {
  YAML::Node merged;
  for (const StageConfig::Layer& layer : layers) merged = mergeNodes(merged, layer.node);
  if (!merged.IsDefined() || merged.IsNull()) return "";
  merged["pipeline"] = pipeline;
  merged["world_frame"] = world_frame;
  merged["floor_max_flatness_m"] = formatDouble(floor_max_flatness_m);
  YAML::Emitter out;
  out << merged;
  return out.c_str();
}

RegistrationConfig registrationConfigFromYaml(
    const std::vector<std::pair<std::string, std::string>>& text_and_source) {
  RegistrationConfig config;
  std::set<std::string> known = {"pipeline", "world_frame", "floor_max_flatness_m"};
  for (const auto& [name, description] : StageRegistry::global().list()) known.insert(name);
  for (const auto& [text, source] : text_and_source) {
    auto reader = std::make_shared<YamlReader>(source);
    const YAML::Node root = reader->parse(text);
    reader->checkConfigRoot(root, text);
    config.files.push_back(source);
    config.readers.push_back(reader);
    StageConfig::Layer layer;
    layer.reader = reader.get();
    if (root.IsDefined() && !root.IsNull()) {
      if (!root.IsMap()) throw Error(ErrorContext{source, 0, "", ""}, "expected a YAML mapping");
      const YAML::Node section = root["register"];
      if (section && !section.IsNull()) {
        reader->rejectUnknownKeys(section, known, "register");
        layer.node = section;
        readFrameKeys(*reader, section, config);
        if (const YAML::Node pipeline = section["pipeline"]; pipeline) {
          if (!pipeline.IsSequence() || pipeline.size() == 0) {
            throw Error(reader->at(pipeline, "register.pipeline"),
                        "expected a list of stage names");
          }
          config.pipeline.clear();
          for (std::size_t i = 0; i < pipeline.size(); ++i) {
            const std::string name =
                reader->text(pipeline[i], "register.pipeline[" + std::to_string(i) + "]");
            if (!StageRegistry::global().has(name)) {
              throw Error(reader->at(pipeline[i], "register.pipeline"),
                          "unknown stage '" + name + "'");
            }
            config.pipeline.push_back(name);
          }
        }
      }
    }
    config.layers.push_back(layer);
  }
  if (config.pipeline.empty()) {
    throw Error(ErrorContext{"", 0, "register.pipeline", ""}, "no stage configured");
  }
  return config;
}

RegistrationConfig registrationConfigFrom(const std::vector<ConfigLayer>& layers) {
  std::vector<std::pair<std::string, std::string>> texts;
  for (const ConfigLayer& layer : layers) texts.emplace_back(layer.text, layer.source);
  return registrationConfigFromYaml(texts);
}

RegistrationConfig loadRegistrationConfig(const std::optional<fs::path>& user_file,
                                          const std::string& overrides) {
  return registrationConfigFrom(configurationLayers(user_file, overrides));
}

// ---- input ----

std::string RegisterOptions::check() const {
  if (dataset.empty()) return "'dataset': missing";
  return "";
}

RegistrationInput loadRegistrationInput(const RegisterOptions& options,
                                        const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  DatasetReadOptions read_options;
  read_options.check_images = false;
  read_options.on_issue = options.on_issue;
  auto reader = DatasetReader::open(options.dataset, read_options);
  RegistrationInput input;
  input.dataset = fs::absolute(options.dataset).lexically_normal();
  input.manifest = reader->manifest();
  input.mode = options.mode;
  const std::string dataset = options.dataset.string();
  std::string label = options.trajectory_label;
  if (label.empty()) label = options.mode == TrajectoryMode::kVisual ? "vo" : "odometry";
  const bool from_file = !options.trajectory_file.empty();
  if (from_file) {
    input.trajectory = readTumFile(options.trajectory_file);
    input.trajectory_label = options.trajectory_file.string();
  } else {
    input.trajectory_label = label;
    const TrajectoryInfo* info = input.manifest.findTrajectory(label);
    if (!info) {
      std::string available;
      for (const TrajectoryInfo& t : input.manifest.trajectories) {
        available += (available.empty() ? "" : ", ") + t.label;
      }
      if (options.mode == TrajectoryMode::kVisual && label == "vo") {
        throw Error(ErrorContext{dataset, 0, "", ""},
                    "no visual odometry trajectory 'vo' in this dataset: run `lookboth odometry " +
                        dataset +
                        "` first, or register with --trajectory metric (trajectories present: " +
                        (available.empty() ? "none" : available) + ")");
      }
      throw Error(ErrorContext{dataset, 0, "", ""},
                  "no trajectory '" + label + "' in this dataset (present: " +
                      (available.empty() ? "none" : available) + ")");
    }
    if (options.mode == TrajectoryMode::kMetric && !info->metric) {
      throw Error(ErrorContext{dataset, 0, "", ""},
                  "trajectory '" + label +
                      "' is not metric (up to scale): register it with --trajectory visual");
    }
  }
  const CameraSensor* fisheye = input.manifest.fisheye();
  std::vector<StampedPose> samples;
  std::int64_t count = 0;
  const std::int64_t expected = reader->expectedCount();
  while (auto record = reader->next()) {
    if (++count % 10000 == 0) {
      progress.checkStop();
      progress.report("read", count, std::max<std::int64_t>(expected, 0));
    }
    if (auto* m = std::get_if<MarkerObservation>(&*record)) {
      input.markers.push_back(std::move(*m));
    } else if (auto* b = std::get_if<BlobObservation>(&*record)) {
      if (!fisheye || b->camera == fisheye->label) input.blobs.push_back(std::move(*b));
    } else if (auto* p = std::get_if<PoseSample>(&*record)) {
      if (!from_file && p->label == label) samples.push_back({p->t, p->world_from_body});
    }
  }
  if (!from_file) {
    std::stable_sort(samples.begin(), samples.end(),
                     [](const StampedPose& a, const StampedPose& b) { return a.t < b.t; });
    samples.erase(
        std::unique(samples.begin(), samples.end(),
                    [](const StampedPose& a, const StampedPose& b) { return a.t == b.t; }),
        samples.end());
    input.trajectory = Trajectory(std::move(samples));
  }
  std::stable_sort(input.blobs.begin(), input.blobs.end(),
                   [](const BlobObservation& a, const BlobObservation& b) { return a.t < b.t; });
  progress.report("read", count, count);
  return input;
}

// ---- controller ----

RegistrationController::RegistrationController(RegistrationConfig config, StageRegistry& registry)
    : config_(std::move(config)) {
  for (const std::string& name : config_.pipeline) {
    stages_.push_back(registry.create(name, config_.stageConfig(name)));
  }
}

namespace {

std::string utcNow() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  std::ostringstream out;
  out << std::put_time(&tm, "%Y-%m-%dT%H:%M:%SZ");
  return out.str();
}

}  // namespace

RegistrationSession::RegistrationSession(const RegistrationController& controller,
                                         RegistrationInput input)
    : controller_(&controller) {
  problem_.input = std::move(input);
  Registration& r = problem_.result;
  r.dataset = problem_.input.dataset.string();
  r.created = utcNow();
  r.versions = {{"lookboth", versionString()},
                {"mrpt", std::to_string((MRPT_VERSION >> 8) & 0xF) + "." +
                             std::to_string((MRPT_VERSION >> 4) & 0xF) + "." +
                             std::to_string(MRPT_VERSION & 0xF)},
                {"opencv", CV_VERSION},
                {"ceres", CERES_VERSION_STRING}};
  r.trajectory_mode = problem_.input.mode;
  r.trajectory_label = problem_.input.trajectory_label;
  r.config_yaml = controller.config_.mergedYaml();
}

std::size_t RegistrationSession::stageCount() const { return controller_->stages_.size(); }

const std::string& RegistrationSession::stageName(std::size_t i) const {
  return controller_->config_.pipeline.at(i);
}

void RegistrationSession::runNext(const ProgressReporter& progress) {
  if (finished()) {
    throw Error(ErrorContext{"", 0, "register.pipeline", ""},
                "every configured stage has run already");
  }
  progress.checkStop();
  RegistrationStage& stage = *controller_->stages_[next_];
  const auto start = std::chrono::steady_clock::now();
  stage.run(problem_, progress);
  Registration& r = problem_.result;
  r.pipeline.push_back(stage.name());
  r.statistics.seconds_per_stage[stage.name()] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ++next_;
}

FacilityCheck RegistrationSession::updateRecord(const Registration& record,
                                                const FacilityCheckOptions& options,
                                                const ProgressReporter& progress) {
  if (!finished()) throw Error("update: the configured stages have not all run");
  if (record_)
    throw Error("update: this registration is a record updated already: run the stages again");
  const auto& names = controller_->config_.pipeline;
  const auto joint = std::find(names.begin(), names.end(), "joint");
  if (joint == names.end()) {
    throw Error(ErrorContext{"", 0, "register.pipeline", ""},
                "--update needs the stage 'joint' in register.pipeline (it holds the unchanged "
                "cameras at the record)");
  }
  progress.checkStop();
  FacilityCheck check = checkFacility(current().registration, record, options);
  // On a copy: a failed or stopped update leaves the registration as it was.
  RegistrationProblem updated = problem_;
  holdAtRecord(updated, record, check);
  RegistrationStage& stage = *controller_->stages_[joint - names.begin()];
  const auto start = std::chrono::steady_clock::now();
  stage.run(updated, progress);
  updated.result.statistics.seconds_per_stage["update"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  updated.result.pipeline.push_back("update");
  problem_ = std::move(updated);
  record_ = record;
  check_ = std::move(check);
  return check_;
}

RegistrationRun RegistrationSession::current() const {
  RegistrationRun run;
  run.registration = record_ ? mergeIntoRecord(*record_, problem_.result, check_) : problem_.result;
  Registration& r = run.registration;
  r.scale = problem_.scale;
  if (problem_.input.mode == TrajectoryMode::kMetric) r.scale_sigma = 0;
  r.trajectory.clear();
  if (problem_.metric_trajectory) {
    r.trajectory = *problem_.metric_trajectory;
  } else {
    for (const StampedPose& p : problem_.input.trajectory.samples()) {
      r.trajectory.push_back({p.t, problem_.metricWorldFromFisheye(p.world_from_body)});
    }
  }
  std::sort(
      r.cameras.begin(), r.cameras.end(),
      [](const CameraRegistration& a, const CameraRegistration& b) { return a.label < b.label; });
  for (const auto& [label, indices] : problem_.inliers_by_camera) {
    const CameraRegistration* camera = r.findCamera(label);
    if (!camera || camera->status == CameraStatus::kUnregistered) continue;
    for (std::size_t a : indices) {
      const Rigid3d marker =
          camera->world_from_camera * problem_.marker(problem_.associations[a]).camera_from_marker;
      run.rays.push_back({camera->world_from_camera.translation, marker.translation});
    }
  }
  return run;
}

RegistrationSession RegistrationController::prepare(RegistrationInput input) const {
  return RegistrationSession(*this, std::move(input));
}

RegistrationRun RegistrationController::run(RegistrationInput input,
                                            const ProgressReporter& progress) const {
  RegistrationSession session = prepare(std::move(input));
  while (!session.finished()) session.runNext(progress);
  return session.current();
}

// ---- output ----

void checkRegistrationOutput(const fs::path& dir, bool overwrite,
                             const std::vector<fs::path>& inputs) {
  checkOutputPath(dir, inputs, /*overwrite=*/true);
  const fs::path target = fs::absolute(dir).lexically_normal();
  if (fs::exists(target) && !overwrite) {
    throw Error(ErrorContext{dir.string(), 0, "", ""}, "already exists (use --overwrite)");
  }
  if (!fs::is_directory(target.parent_path())) {
    throw Error(ErrorContext{dir.string(), 0, "", ""}, "its parent directory does not exist");
  }
}

void writeRegistrationOutput(const RegistrationRun& run, const fs::path& dir, bool overwrite) {
  checkRegistrationOutput(dir, overwrite);
  writeDirectoryAtomically(dir, [&](const fs::path& temporary) {
    saveRegistration(run.registration, temporary);
    writeRegistrationScene(run, temporary / "scene.3Dscene");
  });
}

}  // namespace lookboth
