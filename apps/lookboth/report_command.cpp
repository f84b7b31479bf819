// `lookboth report`: one self-contained HTML file with the verdict, the
// per-camera table, the paper-style tables and the pictures.
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/progress.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/report/report.h"
#include "signals.h"

namespace lookboth::app {
namespace {

struct ReportArgs {
  std::string dataset;
  std::string registration;
  std::string out;
  std::string ground_truth;
  std::string against;
  std::string record;
  FacilityCheckOptions recheck;
  std::string frames = "auto";
  std::string size;
  bool with_scale = false;
  bool no_overview = false;
  bool overwrite = false;
  double max_reprojection_px = 0;
};

int runReport(const ReportArgs& args) {
  report::ReportOptions options;
  options.out = args.out;
  options.ground_truth = args.ground_truth;
  options.against = args.against;
  options.record = args.record;
  options.recheck = args.recheck;
  options.with_scale = args.with_scale;
  options.frames = report::FrameSelection::parse(args.frames);
  if (!args.size.empty()) options.size = report::parseSize(args.size);
  options.overview = !args.no_overview;
  options.max_reprojection_rms_px = args.max_reprojection_px;
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  std::vector<std::filesystem::path> inputs = datasetPaths(args.dataset);
  for (const std::string& p : {args.registration, args.ground_truth, args.against, args.record}) {
    if (!p.empty()) inputs.emplace_back(p);
  }
  checkOutputPath(args.out, inputs, args.overwrite);

  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  try {
    const report::ReportSummary summary =
        report::writeReport(args.dataset, args.registration, options, progress);
    std::cout << "verdict: " << report::verdictName(summary.verdict) << "\n";
    for (const std::string& reason : summary.reasons) std::cout << "  - " << reason << "\n";
    std::cout << "wrote " << args.out << " (" << summary.pictures << " pictures, "
              << formatFixed(summary.bytes / 1e6, 1) << " MB, self-contained)\n";
    std::cout << "open it in a browser: file://"
              << std::filesystem::absolute(args.out).lexically_normal().string() << "\n";
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; " << args.out << " was not written\n";
    return 130;
  }
}

}  // namespace

void registerReportCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<ReportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "report", "A self-contained HTML report of a registration: verdict, tables, pictures");
  cmd->add_option("dataset", args->dataset, "The dataset registered (.rawlog, manifest or folder)")
      ->required();
  cmd->add_option("registration", args->registration, "Registration directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--out", args->out, "The HTML file to write")->required();
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing --out");
  cmd->add_option("--ground-truth", args->ground_truth,
                  "Compare with ground truth (dataset, folder or cameras.csv)");
  cmd->add_option("--against", args->against, "Compare with another registration directory");
  cmd->add_option("--record", args->record,
                  "The facility's registration on record: re-check this drive against it (which "
                  "cameras moved, as lookboth check)")
      ->check(CLI::ExistingDirectory);
  addMoveTolerances(cmd, args->recheck, "With --record: ");
  cmd->add_flag("--with-scale", args->with_scale, "Align comparisons with Sim(3)");
  cmd->add_option("--frames", args->frames, "Fisheye frames shown: auto, i,j,k or t0:t1 [s]")
      ->capture_default_str();
  cmd->add_option("--size", args->size, "Size WxH of every picture");
  cmd->add_flag("--no-overview", args->no_overview, "Skip the 3-D overview (needs EGL)");
  cmd->add_option("--max-reprojection-px", args->max_reprojection_px,
                  "Verdict bound on the reprojection RMS after refinement [px] (0: 3 px at "
                  "1920 px fisheye width, scaled, at least 2 px)")
      ->check(CLI::NonNegativeNumber);
  cmd->callback([args, set_body] { set_body([args] { return runReport(*args); }); });
}

}  // namespace lookboth::app
