#include "lookboth/studio/step_runner.h"

#include <map>
#include <utility>

#include "lookboth/calib/problem.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/studio/pipeline_steps.h"

namespace lookboth::studio {

StepRunner::StepRunner(FullPipelineOptions options) : options_(std::move(options)) {}

StepRunner::~StepRunner() = default;

StepResult StepRunner::run(int step, const std::string& name, const ProgressReporter& progress) {
  if (!pipeline_) pipeline_ = std::make_unique<RegistrationPipeline>(options_);
  RegistrationPipeline& pipeline = *pipeline_;
  while (pipeline.stepsRun() < static_cast<std::size_t>(step) && !pipeline.finished())
    pipeline.runNext(progress);
  if (step < 0 || pipeline.finished() || pipeline.stepsRun() != static_cast<std::size_t>(step) ||
      pipeline.steps()[pipeline.stepsRun()] != name)
    throw Error(ErrorContext{"", 0, "register.pipeline", ""},
                "the step '" + name + "' is not step " + std::to_string(step + 1) +
                    " of the configured pipeline");
  const StepOutcome outcome = pipeline.runNext(progress);
  if (step >= PipelineSteps::kPreparationSteps) return afterStage(name, progress);
  // Detection and odometry add to the dataset: the views read it again.
  StepResult result;
  result.outcome = outcome;
  if (outcome.ran)
    result.index =
        std::make_shared<const DatasetIndex>(DatasetIndex::build(options_.dataset, progress));
  return result;
}

StepResult StepRunner::afterStage(const std::string& name, const ProgressReporter& progress) {
  RegistrationPipeline& pipeline = *pipeline_;
  StepResult result;
  // The registration directory, written after the last stage.
  if (!pipeline.finished() && pipeline.steps()[pipeline.stepsRun()] == "output") {
    pipeline.runNext(progress);
    result.written = true;
  }
  const RegistrationSession& session = *pipeline.session();
  // After the output: the registration as written (in its configured frame).
  RegistrationRun run = result.written ? *pipeline.written() : session.current();
  result.outcome.ran = true;
  result.outcome.summary = name + ": " + stageSummary(name, session.problem(), run.registration) +
                           (result.written ? "; written to " + options_.out.string() : "");
  result.rays = std::move(run.rays);
  result.registration = std::make_shared<const Registration>(std::move(run.registration));
  return result;
}

StepResult StepRunner::updateRecord(const std::string& record, const std::string& out,
                                    const ProgressReporter& progress) {
  if (!pipeline_ || !pipeline_->finished()) {
    throw Error("update: run every step of the pipeline first");
  }
  StepResult result;
  result.check = std::make_shared<const FacilityCheck>(
      pipeline_->updateRecord(record, FacilityCheckOptions(), out, progress));
  RegistrationRun run = *pipeline_->written();
  const FacilityCheck& c = *result.check;
  result.outcome.ran = true;
  result.outcome.summary = "update of " + record + ": " + std::to_string(c.moved) + " moved and " +
                           std::to_string(c.added) + " new registered again, " +
                           std::to_string(c.unchanged) + " unchanged held at the record, " +
                           std::to_string(c.not_seen) + " not seen kept; written to " + out;
  result.written = true;
  result.rays = std::move(run.rays);
  result.registration = std::make_shared<const Registration>(std::move(run.registration));
  return result;
}

std::string stepTitle(const std::string& name) {
  static const std::map<std::string, std::string> titles = {
      {"detect", "Detect markers and blobs"},
      {"odometry", "Visual odometry"},
      {"associate", "Associate detections"},
      {"motion_calibration", "Calibrate (marker on robot)"},
      {"fixed_mount", "Marker mount (fixed)"},
      {"look_down", "Look down (camera poses)"},
      {"look_up", "Look up (refine)"},
      {"joint", "Joint refinement"}};
  const auto it = titles.find(name);
  return it == titles.end() ? name : it->second;
}

std::string stageSummary(const std::string& name, const RegistrationProblem& problem,
                         const Registration& registration) {
  const std::string cameras = std::to_string(registration.registeredCount()) + " of " +
                              std::to_string(registration.cameras.size()) + " cameras registered";
  if (name == "associate")
    return std::to_string(problem.associations.size()) + " of " +
           std::to_string(problem.input.markers.size()) +
           " marker detections associated with the trajectory";
  if (name == "motion_calibration" || name == "fixed_mount") {
    std::string line = "scale " + formatFixed(problem.scale, 4);
    if (problem.fisheye_from_marker) {
      const Eigen::Vector3d t = problem.fisheye_from_marker->translation;
      line += ", marker at [" + formatFixed(t.x(), 3) + ", " + formatFixed(t.y(), 3) + ", " +
              formatFixed(t.z(), 3) + "] m from the fisheye";
    }
    return line;
  }
  if (name == "look_up" && registration.reprojection)
    return cameras + ", fisheye reprojection RMS " +
           formatFixed(registration.reprojection->rms_px_before, 2) + " -> " +
           formatFixed(registration.reprojection->rms_px_after, 2) + " px";
  return cameras;
}

}  // namespace lookboth::studio
