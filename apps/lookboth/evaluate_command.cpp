// `lookboth evaluate`: a registration against ground truth (SE(3)/Sim(3)
// Umeyama alignment, per-camera and RMS errors), against another registration
// (the paper's Table II) and its fisheye reprojection RMSE before and after
// the looking-up refinement (Table I). Writes <registration dir>/evaluation.json.
#include <filesystem>
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/report/pose_comparison.h"

namespace lookboth::app {
namespace {

struct EvaluateArgs {
  std::string registration;
  std::string ground_truth;
  std::string against;
  std::string json;
  bool with_scale = false;
  bool overwrite = false;
};

/// Refuses a --json that would overwrite what is evaluated; the default
/// <registration>/evaluation.json is the registration's own and is replaced.
void checkJsonOutput(const EvaluateArgs& args) {
  if (args.json.empty()) return;
  std::vector<std::filesystem::path> inputs;
  for (const std::string& p : {args.ground_truth, args.against}) {
    if (p.empty()) continue;
    for (const auto& part : datasetPaths(p)) inputs.push_back(part);
  }
  for (const auto& entry : std::filesystem::directory_iterator(args.registration)) {
    if (entry.path().filename() != "evaluation.json") inputs.push_back(entry.path());
  }
  inputs.emplace_back(args.registration);
  checkOutputPath(args.json, inputs, args.overwrite, "--json");
}

int runEvaluate(const EvaluateArgs& args) {
  report::EvaluateOptions options;
  options.ground_truth = args.ground_truth;
  options.against = args.against;
  options.with_scale = args.with_scale;
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  checkJsonOutput(args);
  const report::Evaluation evaluation = report::evaluateRegistration(args.registration, options);
  if (evaluation.ground_truth) {
    std::cout << report::formatComparisonTable(*evaluation.ground_truth,
                                               "Against ground truth (estimate - truth):");
    std::cout << "\n";
  }
  if (evaluation.against) {
    std::cout << report::formatComparisonTable(*evaluation.against,
                                               "Against " + args.against + ":");
    std::cout << "RMS differences per axis (paper's Table II form):\n"
              << report::formatTableTwoRow(*evaluation.against,
                                           args.against + " <-> " + args.registration)
              << "\n";
  }
  if (evaluation.reprojection) {
    std::cout << "Fisheye reprojection of the camera positions (paper's Table I):\n"
              << report::formatReprojectionTable(*evaluation.reprojection);
    if (evaluation.reported_reprojection) {
      std::cout << "  (registration.yaml reports " << evaluation.reported_reprojection->blobs
                << " blobs, RMSE before "
                << formatFixed(evaluation.reported_reprojection->rms_px_before, 3) << " px, after "
                << formatFixed(evaluation.reported_reprojection->rms_px_after, 3) << " px)\n";
    }
  } else {
    std::cout << "Fisheye reprojection: no blob association in this registration "
                 "(the looking-up stage did not run)\n";
  }
  const std::filesystem::path json =
      args.json.empty() ? std::filesystem::path(args.registration) / "evaluation.json"
                        : std::filesystem::path(args.json);
  report::writeEvaluationJson(evaluation, json);
  std::cout << "wrote " << json.string() << "\n";
  return 0;
}

}  // namespace

void registerEvaluateCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<EvaluateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "evaluate",
      "Compare a registration with ground truth or another registration; reprojection RMSE");
  cmd->add_option("registration", args->registration,
                  "Registration directory (lookboth register --out)")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--ground-truth", args->ground_truth,
                  "Ground truth: a dataset (.rawlog or manifest), a dataset folder, or a "
                  "cameras.csv (label,tx,ty,tz,qx,qy,qz,qw)");
  cmd->add_option("--against", args->against, "Another registration directory (Table II)");
  cmd->add_flag("--with-scale", args->with_scale,
                "Align with a similarity (Sim(3)) instead of a rigid transform");
  cmd->add_option("--json", args->json,
                  "Where to write the JSON (default: <registration>/evaluation.json)");
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing --json");
  cmd->callback([args, set_body] { set_body([args] { return runEvaluate(*args); }); });
}

}  // namespace lookboth::app
