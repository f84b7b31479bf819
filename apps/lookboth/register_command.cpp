// `lookboth register`: a dataset's detections and trajectory -> the pose of
// every environment camera (libs/calib does the work; doc/user-guide.md).
#include <filesystem>
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/pipeline/full_pipeline.h"
#include "lookboth/pipeline/registration_controller.h"
#include "signals.h"

namespace lookboth::app {
namespace {

struct RegisterArgs {
  std::string dataset;
  std::string out;
  std::string trajectory;  ///< "" = chosen from the dataset (chooseTrajectory).
  std::string trajectory_label;
  std::string trajectory_file;
  std::string config;
  bool overwrite = false;
  bool no_detect = false;
  bool no_odometry = false;
  bool no_write_back = false;
  bool sequential = false;
  bool verbose = false;
  int threads = 0;
  std::string update;  ///< A registration on record to update.
  FacilityCheckOptions update_check;
};

/// The files register reads: it must not write over any of them.
std::vector<std::filesystem::path> registerInputs(const RegisterArgs& args) {
  std::vector<std::filesystem::path> inputs = datasetPaths(args.dataset);
  if (!args.trajectory_file.empty()) inputs.emplace_back(args.trajectory_file);
  if (!args.config.empty()) inputs.emplace_back(args.config);
  if (!args.update.empty()) inputs.emplace_back(args.update);
  return inputs;
}

int runRegister(const RegisterArgs& args) {
  RegisterOptions options;
  options.dataset = args.dataset;
  if (!args.trajectory.empty()) options.mode = *parseTrajectoryMode(args.trajectory);
  options.trajectory_label = args.trajectory_label;
  options.trajectory_file = args.trajectory_file;
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  // Before the work, not after it (the output is written once all is done).
  checkRegistrationOutput(args.out, args.overwrite, registerInputs(args));

  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  try {
    // Detection and odometry first when the dataset lacks their outputs
    // (runFullPipeline says what it ran and why), then the stages, then the output.
    FullPipelineOptions full;
    full.dataset = options.dataset;
    full.out = args.out;
    full.overwrite = args.overwrite;
    full.choose_trajectory = args.trajectory.empty() && args.trajectory_label.empty();
    full.mode = options.mode;
    full.trajectory_label = options.trajectory_label;
    full.trajectory_file = options.trajectory_file;
    if (!args.config.empty()) full.config_file = std::filesystem::path(args.config);
    full.auto_detect = !args.no_detect;
    full.auto_odometry = !args.no_odometry;
    full.threads = args.threads;
    full.write_back = !args.no_write_back;
    full.overlap_steps = !args.sequential;
    full.on_issue = printDatasetIssue;
    full.update_record = args.update;
    full.update_check = args.update_check;
    const FullPipelineResult result = runFullPipeline(full, progress);
    for (const auto& step : result.steps) std::cout << step << "\n";
    if (result.check) {
      std::cout << "this drive against " << args.update << ":\n";
      printFacilityCheck(*result.check, args.update_check);
    }
    const RegistrationRun& run = result.run;
    std::cout << registrationSummary(run.registration, args.verbose);
    std::cout << describeTimes(result) << "\n";
    std::cout << "wrote " << args.out << "\n";
    if (run.registration.registeredCount() == 0) {
      std::cerr << "lookboth: no camera could be registered\n";
      return 1;
    }
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; " << args.out << " was not written\n";
    return 130;
  }
}

}  // namespace

void registerRegisterCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<RegisterArgs>();
  CLI::App* cmd = app.add_subcommand(
      "register", "Register the environment cameras of a dataset (the paper's method)");
  cmd->add_option("dataset", args->dataset, "The dataset (x.rawlog or a folder)")->required();
  cmd->add_option("--out", args->out, "Output directory (cameras.csv, registration.yaml, ...)")
      ->required();
  cmd->add_option("--trajectory", args->trajectory,
                  "visual: a trajectory up to scale (the scale is estimated; label 'vo' unless "
                  "--trajectory-label); metric: a metric trajectory, scale 1 (label 'odometry' "
                  "unless --trajectory-label). Default: chosen from the dataset, in this order: "
                  "its visual odometry 'vo'; its only trajectory marked not metric; visual "
                  "odometry run on its fisheye frames; its metric 'odometry' (or its only "
                  "metric one). The first output line says which")
      ->check(CLI::IsMember({"visual", "metric"}));
  cmd->add_option("--trajectory-label", args->trajectory_label,
                  "The dataset trajectory to use (with visual mode unless --trajectory metric)");
  cmd->add_option("--trajectory-file", args->trajectory_file,
                  "A TUM file (world_from_fisheye, robot clock) instead of a dataset trajectory")
      ->check(CLI::ExistingFile);
  cmd->add_option("--config", args->config,
                  "A YAML file over share/lookboth/config/default.yaml: the keys it sets in "
                  "'register:', 'detect:' and 'odometry:' replace the defaults")
      ->check(CLI::ExistingFile);
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing output directory");
  cmd->add_flag("--verbose", args->verbose,
                "Also print what the data determines and the notes (nothing to act on); both "
                "are in registration.yaml too");
  cmd->add_flag("--no-detect", args->no_detect,
                "Do not run the detection when the dataset has frames but no detections");
  cmd->add_flag("--no-odometry", args->no_odometry,
                "Do not run the visual odometry when the dataset has no 'vo' trajectory");
  cmd->add_option("--threads", args->threads, "Detection threads (0 = one per core)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--sequential", args->sequential,
                "Run the detection, then the odometry (by default, when both are needed, the "
                "odometry runs beside detection, on threads of its own)");
  cmd->add_option("--update", args->update,
                  "A registration on record (a directory) to bring up to date with this drive: "
                  "the drive is registered, compared with the record as `lookboth check` does, "
                  "and registered again in the record's frame with the unchanged cameras held "
                  "at the record (their recorded covariance as the weight); the moved and new "
                  "cameras take the poses found against them, the cameras the drive did not "
                  "see keep the record's. --out is the record updated")
      ->check(CLI::ExistingDirectory);
  addMoveTolerances(cmd, args->update_check, "With --update: ");
  cmd->add_flag("--no-write-back", args->no_write_back,
                "Leave the dataset untouched: the detections and odometry that register runs "
                "go to a temporary copy beside --out, removed at the end (by default they are "
                "added to the dataset, for the next run, the report and the desktop app)");
  cmd->callback([args, set_body] { set_body([args] { return runRegister(*args); }); });
}

}  // namespace lookboth::app
