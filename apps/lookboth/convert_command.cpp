// `lookboth convert`: datasets between the rawlog and folder layouts, TUM
// trajectories in and out, ROS 1 bags in.
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/progress.h"
#include "lookboth/dataset/convert.h"
#include "signals.h"

namespace lookboth::app {
namespace {

struct ConvertArgs {
  std::string from, to, from_kind = "auto", to_kind = "auto", label;
  bool overwrite = false, strict = false, scaled = false;
  std::vector<std::string> trajectories;
};

// "file.tum=label[:metric|:scaled]"
TrajectoryInput parseTrajectoryArg(const std::string& text) {
  const size_t eq = text.rfind('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size()) {
    throw Error("'--trajectory': expected FILE.tum=LABEL[:metric|:scaled], got '" + text + "'");
  }
  TrajectoryInput input;
  input.file = text.substr(0, eq);
  std::string label = text.substr(eq + 1);
  const size_t colon = label.find(':');
  if (colon != std::string::npos) {
    const std::string kind = label.substr(colon + 1);
    label = label.substr(0, colon);
    if (kind == "scaled") {
      input.info.metric = false;
    } else if (kind != "metric") {
      throw Error("'--trajectory': unknown kind '" + kind + "' (metric or scaled)");
    }
  }
  input.info.label = label;
  input.info.description = "added from " + input.file.filename().string();
  return input;
}

int runConvert(const ConvertArgs& args) {
  ConvertOptions options;
  options.from = args.from;
  options.to = args.to;
  options.from_kind = *parseDataKind(args.from_kind);
  options.to_kind = *parseDataKind(args.to_kind);
  options.overwrite = args.overwrite;
  options.strict = args.strict;
  options.trajectory_label = args.label;
  options.trajectory_metric = !args.scaled;
  for (const std::string& t : args.trajectories) options.add_trajectories.push_back(parseTrajectoryArg(t));
  options.on_issue = [](const DatasetIssue& issue) {
    std::cerr << "lookboth: warning: " << issue.where << ": " << issue.message << "\n";
  };
  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  try {
    const ConvertSummary summary = convertData(options, progress);
    std::cout << "wrote " << args.to << ": " << summary.total() << " records";
    std::string sep = " (";
    for (const auto& [kind, count] : summary.records) {
      std::cout << sep << kind << ": " << count;
      sep = ", ";
    }
    std::cout << (summary.records.empty() ? "" : ")") << "\n";
    if (!summary.issues.empty()) std::cout << summary.issues.size() << " warning(s), see above\n";
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; " << args.to << " was not written\n";
    return 130;
  }
}

}  // namespace

void registerConvertCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<ConvertArgs>();
  CLI::App* cmd = app.add_subcommand(
      "convert", "Convert between dataset layouts (rawlog, folder), TUM trajectories and ROS 1 bags");
  const auto kinds = CLI::IsMember({"auto", "rawlog", "folder", "bag", "tum"});
  cmd->add_option("--from", args->from, "Input: x.rawlog (with x.yaml beside it), a folder, x.bag, x.tum")
      ->required();
  cmd->add_option("--to", args->to, "Output: x.rawlog, a folder, or x.tum (a trajectory)")->required();
  cmd->add_option("--from-kind", args->from_kind, "Force the input kind")->check(kinds);
  cmd->add_option("--to-kind", args->to_kind, "Force the output kind")->check(kinds);
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing output");
  cmd->add_flag("--strict", args->strict, "Treat input warnings (duplicates, missing images) as errors");
  cmd->add_option("--label", args->label,
                  "Trajectory label: which one to export to TUM, or the label of an imported TUM file");
  cmd->add_flag("--scaled", args->scaled, "An imported TUM trajectory is up to scale (monocular VO)");
  cmd->add_option("--trajectory", args->trajectories,
                  "Add a TUM trajectory to the output dataset: FILE.tum=LABEL[:metric|:scaled]");
  cmd->callback([args, set_body] { set_body([args] { return runConvert(*args); }); });
}

}  // namespace lookboth::app
