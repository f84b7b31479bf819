// `lookboth odometry`: fisheye visual odometry over a dataset -> a TUM
// trajectory (world = first keyframe, unknown scale) and statistics.
#include <iomanip>
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/paths.h"
#include "lookboth/core/progress.h"
#include "lookboth/core/text.h"
#include "lookboth/vo/run.h"
#include "signals.h"

namespace lookboth::app {
namespace {

struct OdometryArgs {
  std::string dataset;
  std::string config;
  std::string tum;
  std::string map;
  std::string camera;
  int threads = 1;
  long long seed = -1;
  double duration = 0;
  bool no_loop_closure = false;
  std::string out;
  bool overwrite = false;
  bool dry_run = false;
};

void printAte(const char* what, const std::optional<vo::AteResult>& ate) {
  if (!ate) return;
  std::cout << "  " << what << formatFixed(ate->rmse, 4) << " m RMSE over " << ate->matched
            << " poses, " << formatFixed(ate->percent(), 3) << " % of "
            << formatFixed(ate->path_length, 2) << " m (Sim(3)-aligned, scale "
            << formatFixed(ate->scale, 4) << ")\n";
}

int runOdometryCommand(const OdometryArgs& args) {
  vo::OdometryRunOptions options;
  options.dataset = args.dataset;
  options.odometry = vo::odometryOptionsFor(
      args.config.empty() ? std::nullopt : std::optional<std::filesystem::path>(args.config));
  options.odometry.threads = args.threads;
  if (args.seed >= 0) options.odometry.seed = static_cast<std::uint32_t>(args.seed);
  if (args.no_loop_closure) options.odometry.loop_closure = false;
  options.tum_out = args.tum;
  options.map_out = args.map;
  options.out = args.out;
  options.overwrite = args.overwrite;
  options.write_dataset = !args.dry_run;
  options.camera = args.camera;
  options.max_duration_s = args.duration;
  options.on_issue = printDatasetIssue;
  if (const std::string why = options.check(); !why.empty()) throw Error(why);

  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  try {
    const vo::OdometryRunSummary s = vo::runOdometry(options, progress);
    const vo::OdometryStatistics& st = s.result.statistics;
    std::cout << "odometry of " << args.dataset << " (camera " << s.camera << ", working "
              << s.working_width << "x" << s.working_height << ")\n";
    std::cout << "  frames:      " << st.frames << " (" << st.tracked_frames << " with a pose)\n";
    std::cout << "  keyframes:   " << st.keyframes << ", landmarks " << st.landmarks << "\n";
    std::cout << "  features:    " << formatFixed(st.mean_tracked_features, 1) << " tracked, "
              << formatFixed(st.mean_inliers, 1) << " pose inliers per frame\n";
    std::cout << "  loops:       " << st.loop_closures << " closed\n";
    std::cout << "  tracking:    " << st.tracking_losses << " losses, " << st.relocalisations
              << " relocalisations, " << st.segments << " segments (" << st.segments_at_end
              << " at the end)\n";
    std::cout << "  map memory:  " << formatFixed(static_cast<double>(st.map_bytes) / 1024.0, 1)
              << " KiB at the end ("
              << formatFixed(static_cast<double>(st.map_bytes) / 1024.0 /
                                 std::max<double>(1, static_cast<double>(st.keyframes)),
                             2)
              << " KiB per keyframe)\n";
    std::cout << "  global BA:   " << st.global_problems << " problems, the largest "
              << st.global_largest_observations << " observations of "
              << st.global_largest_keyframes << " keyframes\n";
    for (const std::string& e : st.events) std::cout << "  event:       " << e << "\n";
    const double n = std::max<double>(1, static_cast<double>(st.frames));
    std::cout << "  time (CPU):  decode " << formatFixed(s.decode_seconds, 2)
              << " s on the second thread = "
              << formatFixed(n / std::max(s.decode_seconds, 1e-9), 1)
              << " frames/s; tracking+mapping " << formatFixed(s.track_seconds, 2)
              << " s = " << formatFixed(n / std::max(s.track_seconds, 1e-9), 1)
              << " frames/s; final adjustment " << formatFixed(s.finish_seconds, 2) << " s\n";
    std::cout << "  time (wall): " << formatFixed(s.wall_seconds, 2) << " s\n";
    std::cout << "  stages:     ";
    for (const auto& [stage, seconds] : st.stage_seconds)
      std::cout << " " << stage << " " << formatFixed(1000 * seconds / n, 2) << " ms";
    std::cout << " (CPU per frame)\n";
    printAte("ATE frames:  ", s.ate);
    printAte("ATE keyfr.:  ", s.ate_keyframes);
    if (!s.dataset_written.empty())
      std::cout << "wrote " << s.records_written << " poses (trajectory 'vo', up to scale) to "
                << s.dataset_written.string() << "\n";
    if (!args.tum.empty()) std::cout << "wrote " << args.tum << "\n";
    if (!args.map.empty())
      std::cout << "wrote " << s.result.landmarks.size() << " landmarks to " << args.map << "\n";
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; the dataset is unchanged and nothing was written\n";
    return 130;
  }
}

}  // namespace

void registerOdometryCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<OdometryArgs>();
  CLI::App* cmd = app.add_subcommand(
      "odometry",
      "Fisheye visual odometry with loop closure: adds the trajectory 'vo' (up to scale) to the "
      "dataset");
  cmd->add_option("dataset", args->dataset, "Dataset (x.rawlog, its manifest, or a folder)")
      ->required();
  cmd->add_option("--config", args->config,
                  "YAML configuration (section 'odometry:'; default: the shipped default.yaml)");
  cmd->add_option("--out", args->out,
                  "Write the dataset with the trajectory here instead of replacing the input");
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing --out, --tum or --map");
  cmd->add_flag("--dry-run", args->dry_run, "Leave the dataset as it is (statistics, --tum only)");
  cmd->add_option("--tum", args->tum, "Also write the trajectory (world_from_fisheye) as TUM");
  cmd->add_option("--map", args->map,
                  "Also write the landmark map (world of the trajectory, VO units): FILE.ply (PLY "
                  "point cloud) or FILE.txt (MRPT CSimplePointsMap text)");
  cmd->add_option("--camera", args->camera,
                  "The fisheye's label (default: the manifest's fisheye)");
  cmd->add_option("--threads", args->threads, "Solver threads")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->add_option("--seed", args->seed, "RANSAC seed (overrides the configuration)")
      ->check(CLI::Range(0LL, 4294967295LL));
  cmd->add_option("--duration", args->duration, "Only the first SECONDS of frames (0 = all)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--no-loop-closure", args->no_loop_closure, "Odometry only (for comparison)");
  cmd->callback([args, set_body] { set_body([args] { return runOdometryCommand(*args); }); });
}

}  // namespace lookboth::app
