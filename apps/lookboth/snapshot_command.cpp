// `lookboth snapshot`: PNG pictures of a registration, without any display:
// fisheye reprojection checks, environment camera views of the marker, the
// 3-D overview, comparisons with a reference, loop closure.
#include <filesystem>
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/progress.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/registration/registration.h"
#include "lookboth/report/snapshot.h"
#include "signals.h"

namespace lookboth::app {
namespace {

struct SnapshotArgs {
  std::string dataset;
  std::string registration;
  std::string out;
  std::string frames = "auto";
  std::string size;
  std::string ground_truth;
  std::string against;
  bool with_scale = false;
  bool no_overview = false;
  int auto_frames = 6;
  int env_views = 12;
};

/// The pictures go to a folder of their own: not one of the inputs, not
/// inside one (the registration folder is what is being shown), not one
/// that holds an input (the existing pictures are replaced).
void checkSnapshotOutput(const SnapshotArgs& args) {
  std::vector<std::filesystem::path> inputs = datasetPaths(args.dataset);
  for (const std::string& p : {args.registration, args.ground_truth, args.against}) {
    if (p.empty()) continue;
    for (const auto& part : datasetPaths(p)) inputs.push_back(part);
  }
  checkOutputPath(args.out, inputs, /*overwrite=*/true);
  for (const std::filesystem::path& input : inputs) {
    if (std::filesystem::is_directory(input) && contains(input, args.out)) {
      throw Error({args.out, 0, "--out", ""},
                  "is inside the input '" + input.string() +
                      "'; inputs are never written to: choose a folder outside it");
    }
  }
}

int runSnapshot(const SnapshotArgs& args) {
  checkSnapshotOutput(args);
  // Before the references and the registration are loaded (seconds on a
  // large ground-truth dataset): a stop asked then is not lost.
  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  report::SnapshotOptions options;
  options.out = args.out;
  options.frames = report::FrameSelection::parse(args.frames);
  if (!args.size.empty()) options.size = report::parseSize(args.size);
  options.auto_frames = args.auto_frames;
  options.max_env_views = args.env_views;
  options.overview = !args.no_overview;
  options.reference_with_scale = args.with_scale;
  if (!args.ground_truth.empty()) {
    options.references.push_back({"ground_truth", report::loadGroundTruthPoses(args.ground_truth)});
  }
  if (!args.against.empty()) {
    const std::string name =
        std::filesystem::path(args.against).lexically_normal().filename().string();
    options.references.push_back(
        {name.empty() ? "other" : name,
         report::poseSetOfRegistration(loadRegistration(args.against), args.against)});
  }
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  const report::RegistrationView view =
      report::viewOfRegistration(loadRegistration(args.registration), "registration");
  try {
    const report::SnapshotResult result =
        report::writeSnapshots(args.dataset, view, options, progress);
    std::cout << "wrote " << result.pictures.size() << " pictures to " << args.out << "\n";
    for (const report::SnapshotPicture& picture : result.pictures) {
      std::cout << "  " << picture.file.filename().string() << "  (" << picture.size.width << "x"
                << picture.size.height << ")  " << picture.caption << "\n";
    }
    for (const std::string& note : result.notes) std::cout << "  note: " << note << "\n";
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; the pictures written so far are complete\n";
    return 130;
  }
}

}  // namespace

void registerSnapshotCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<SnapshotArgs>();
  CLI::App* cmd =
      app.add_subcommand("snapshot",
                         "PNG pictures of a registration (no display needed): reprojection checks, "
                         "camera views, 3-D overview, comparisons");
  cmd->add_option("dataset", args->dataset, "The dataset registered (.rawlog, manifest or folder)")
      ->required();
  cmd->add_option("registration", args->registration, "Registration directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--out", args->out, "Output folder (created when absent)")->required();
  cmd->add_option("--frames", args->frames,
                  "Fisheye frames: auto (most cameras in view, worst residuals), indices i,j,k, "
                  "or seconds t0:t1 since the first fisheye frame")
      ->capture_default_str();
  cmd->add_option("--size", args->size,
                  "Size WxH of every picture (default: camera pictures at the image size, "
                  "plots and 3-D view 1280x720)");
  cmd->add_option("--ground-truth", args->ground_truth,
                  "Compare with ground truth (dataset, folder or cameras.csv)");
  cmd->add_option("--against", args->against, "Compare with another registration directory");
  cmd->add_flag("--with-scale", args->with_scale, "Align the reference with Sim(3)");
  cmd->add_flag("--no-overview", args->no_overview, "Skip the 3-D overview (needs EGL)");
  cmd->add_option("--auto-frames", args->auto_frames, "Frames picked by --frames auto")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--env-views", args->env_views, "Environment camera pictures at most")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd->callback([args, set_body] { set_body([args] { return runSnapshot(*args); }); });
}

}  // namespace lookboth::app
