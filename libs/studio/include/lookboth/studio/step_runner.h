// One pipeline step per call, for the desktop app: the controller that
// `lookboth register` runs (RegistrationPipeline), kept between the steps so
// that each step is one job the technician starts, watches and can cancel,
// and what each step hands back to the window. No window in it: tested
// without wx.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "lookboth/core/progress.h"
#include "lookboth/pipeline/full_pipeline.h"
#include "lookboth/registration/registration.h"
#include "lookboth/studio/dataset_index.h"

namespace lookboth::studio {

/// What a step gives the window.
struct StepResult {
  StepOutcome outcome;
  /// The dataset read again, when detection or odometry added to it.
  std::shared_ptr<const DatasetIndex> index;
  /// The registration as it stands after a stage.
  std::shared_ptr<const Registration> registration;
  std::vector<DetectionRay> rays;
  bool written = false;  ///< The registration directory was written (after the last stage).
  /// With updateRecord: this drive's registration against the record.
  std::shared_ptr<const FacilityCheck> check;
};

/// Runs the steps of one RegistrationPipeline (made on the first call, with
/// `options` as they are then). Asked for a step beyond the next one, it
/// runs the steps before it first: those the window ran in an earlier
/// runner are done already, and pass as skipped. One call at a time.
class StepRunner {
 public:
  explicit StepRunner(FullPipelineOptions options);
  ~StepRunner();

  /// Runs step `step`, named `name` (PipelineSteps' numbering: detect 0,
  /// odometry 1, then the stages; the controller's "output" goes with the
  /// last stage). Throws lookboth::Error when `name` is not that step of the
  /// configured pipeline, StopRequested when stopped.
  StepResult run(int step, const std::string& name, const ProgressReporter& progress);
  /// Once every step has run: the record in `record` updated by this drive
  /// (RegistrationPipeline::updateRecord, the default tolerances), written
  /// to `out`; the result is the record updated, with the comparison.
  StepResult updateRecord(const std::string& record, const std::string& out,
                          const ProgressReporter& progress);

 private:
  StepResult afterStage(const std::string& name, const ProgressReporter& progress);

  FullPipelineOptions options_;
  std::unique_ptr<RegistrationPipeline> pipeline_;
};

/// What a technician reads for a step (the stage's name when it has no title).
std::string stepTitle(const std::string& name);

/// One line saying what a registration stage gave, from what it wrote.
std::string stageSummary(const std::string& name, const RegistrationProblem& problem,
                         const Registration& registration);

}  // namespace lookboth::studio
