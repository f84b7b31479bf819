// `lookboth simulate`: a scenario (built-in or YAML file) -> a dataset with
// ground truth, rendered or as detections only.
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/progress.h"
#include "lookboth/core/text.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/simulate.h"
#include "signals.h"

namespace lookboth::app {
namespace {

struct SimulateArgs {
  std::string scenario = "small";
  std::string out;
  std::string format = "dataset";
  bool detections_only = false;
  bool overwrite = false;
  long long seed = -1;
  double duration = 0;
  int threads = 0;
};

std::string humanBytes(std::uintmax_t bytes) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB"};
  double value = static_cast<double>(bytes);
  int unit = 0;
  while (value >= 1000 && unit < 4) {
    value /= 1000;
    ++unit;
  }
  return formatFixed(value, unit == 0 ? 0 : 1) + " " + units[unit];
}

int runSimulate(const SimulateArgs& args) {
  sim::SimulateOptions options;
  options.scenario = args.scenario;
  options.out = args.out;
  options.kind = args.format == "folder" ? DatasetKind::kFolder : DatasetKind::kRawlog;
  options.detections_only = args.detections_only;
  options.overwrite = args.overwrite;
  if (args.seed >= 0) {
    if (args.seed > 4294967295LL) throw Error("'--seed': must be in [0, 4294967295]");
    options.seed = static_cast<std::uint32_t>(args.seed);
  }
  options.max_duration_s = args.duration;
  options.threads = args.threads;
  if (const std::string why = options.check(); !why.empty()) throw Error(why);

  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  try {
    const sim::SimulateSummary s = sim::simulate(options, progress);
    std::cout << "wrote " << args.out << " (scenario " << s.scenario << ", seed " << s.seed
              << (args.detections_only ? ", detections only" : "") << ")\n";
    std::cout << "  cameras:     " << s.cameras << " environment cameras + the fisheye\n";
    std::cout << "  path:        " << formatFixed(s.path_length_m, 1) << " m in "
              << formatFixed(s.duration_s, 1) << " s\n";
    std::cout << "  records:     " << s.total();
    std::string sep = " (";
    for (const auto& [kind, count] : s.records) {
      std::cout << sep << kind << ": " << count;
      sep = ", ";
    }
    std::cout << (s.records.empty() ? "" : ")") << "\n";
    std::cout << "  size:        " << humanBytes(s.output_bytes) << "\n";
    for (const std::string& fault : s.faults) std::cout << "  fault:       " << fault << "\n";
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; " << args.out << " was not written\n";
    return 130;
  }
}

}  // namespace

void registerSimulateCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<SimulateArgs>();
  CLI::App* cmd = app.add_subcommand(
      "simulate", "Simulate a facility, its cameras and the robot: a dataset with ground truth");
  cmd->add_option("--scenario", args->scenario,
                  "A built-in scenario (paper, small, revisit, faults) or a scenario YAML file")
      ->capture_default_str();
  cmd->add_option("--out", args->out,
                  "Output: x.rawlog (dataset; manifest and x_Images/ beside it) or a folder "
                  "(--format folder)")
      ->required();
  cmd->add_option("--format", args->format, "dataset (rawlog) or folder")
      ->check(CLI::IsMember({"dataset", "rawlog", "folder"}))
      ->capture_default_str();
  cmd->add_flag("--detections-only", args->detections_only,
                "Write marker poses and blobs directly instead of rendering images");
  cmd->add_option("--seed", args->seed, "Override the scenario's seed")
      ->check(CLI::Range(0LL, 4294967295LL));
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing output");
  cmd->add_option("--duration", args->duration,
                  "Simulate only the first SECONDS of the scenario (0 = all)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--threads", args->threads, "Rendering threads (0 = one per core)")
      ->check(CLI::Range(0, 256));
  cmd->callback([args, set_body] { set_body([args] { return runSimulate(*args); }); });
}

}  // namespace lookboth::app
