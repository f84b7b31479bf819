// `lookboth convert`: datasets between the rawlog and folder layouts, TUM
// trajectories in and out, ROS 1 and ROS 2 bags in.
#include <algorithm>
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/progress.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/augment.h"
#include "lookboth/dataset/convert.h"
#include "lookboth/dataset/rosbag_import.h"
#include "signals.h"

namespace lookboth::app {
namespace {

struct ConvertArgs {
  std::string from, to, from_kind = "auto", to_kind = "auto", label;
  bool overwrite = false, strict = false, scaled = false;
  std::vector<std::string> trajectories;
  // ROS bags
  std::string topics_yaml, marker;
  std::vector<std::string> topics, calibrations;
  bool receive_time = false;
  std::vector<std::string>
      merge;  ///< Datasets to join (the shards of `lookboth detect --cameras`).
  std::vector<std::string> cameras;  ///< Only these cameras (an edge node's part).
  std::vector<std::string> videos;   ///< LABEL=FILE[:start=NS|:times=CSV]
};

// "DICT_4X4_50:7:0.2"
MarkerSpec parseMarkerArg(const std::string& text) {
  const size_t a = text.find(':');
  const size_t b = a == std::string::npos ? a : text.find(':', a + 1);
  if (b == std::string::npos)
    throw Error("'--marker': expected DICTIONARY:ID:SIZE_M, got '" + text + "'");
  MarkerSpec marker;
  marker.dictionary = text.substr(0, a);
  const auto id = parseInt(text.substr(a + 1, b - a - 1));
  const auto size = parseDouble(text.substr(b + 1));
  if (!id || !size) throw Error("'--marker': expected DICTIONARY:ID:SIZE_M, got '" + text + "'");
  marker.id = static_cast<int>(*id);
  marker.size_m = *size;
  if (const std::string why = marker.check(); !why.empty()) throw Error("'--marker': " + why);
  return marker;
}

int runImportBag(const ConvertArgs& args, DataKind to_kind, const ProgressReporter& progress) {
  RosbagImportOptions options;
  if (!args.topics_yaml.empty()) options = loadRosbagMapping(args.topics_yaml);
  for (const std::string& topic : args.topics) options.topics.push_back(parseTopicMapping(topic));
  if (!args.marker.empty()) options.marker = parseMarkerArg(args.marker);
  for (const std::string& c : args.calibrations) {
    const size_t eq = c.find('=');
    if (eq == std::string::npos || eq == 0)
      throw Error("'--calibration': expected LABEL=FILE, got '" + c + "'");
    options.calibration_files[c.substr(0, eq)] = c.substr(eq + 1);
  }
  if (args.receive_time) options.use_header_stamp = false;
  if (options.topics.empty()) {
    throw Error(
        "'--topics'/'--topic': say which bag topics to import, e.g. --topic "
        "/fisheye/image_raw=fisheye:fisheye");
  }
  DatasetWriteOptions write_options;
  write_options.overwrite = args.overwrite;
  const DatasetKind kind =
      to_kind == DataKind::kRawlog ? DatasetKind::kRawlog : DatasetKind::kFolder;
  const RosbagImportStats stats =
      importRosbag(args.from, args.to, kind, options, write_options, progress);
  std::cout << "wrote " << args.to << ": " << stats.records << " records from";
  for (const auto& [topic, count] : stats.messages_per_topic)
    std::cout << " " << topic << " (" << count << ")";
  std::cout << "\n";
  if (!stats.warnings.empty()) std::cout << stats.warnings.size() << " warning(s), see above\n";
  return 0;
}

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

// "cam03=rec.mp4:start=1700000000000000000" or "cam03=rec.mp4:times=rec.csv"
VideoInput parseVideoArg(const std::string& text) {
  const std::string usage =
      "'--video': expected LABEL=FILE[:start=NS|:times=FILE.csv], got '" + text + "'";
  const size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size()) throw Error(usage);
  VideoInput input;
  input.label = text.substr(0, eq);
  std::string rest = text.substr(eq + 1);
  for (const std::string key : {":times=", ":start="}) {
    const size_t at = rest.rfind(key);
    if (at == std::string::npos) continue;
    const std::string value = rest.substr(at + key.size());
    rest.resize(at);
    if (key == ":times=") {
      input.times = value;
    } else if (const std::optional<long long> start = parseInt(value)) {
      input.start = *start;
    } else {
      throw Error("'--video' " + text +
                  ": start must be the first frame's time in integer ns, got '" + value + "'");
    }
  }
  if (rest.empty()) throw Error(usage);
  input.file = rest;
  return input;
}

/// The --video inputs, with the --calibration of the cameras they add.
std::vector<VideoInput> videoInputs(const ConvertArgs& args) {
  std::vector<VideoInput> videos;
  for (const std::string& text : args.videos) videos.push_back(parseVideoArg(text));
  for (const std::string& text : args.calibrations) {
    const size_t eq = text.find('=');
    const std::string label = text.substr(0, eq);
    const auto it = std::find_if(videos.begin(), videos.end(),
                                 [&](const VideoInput& v) { return v.label == label; });
    if (eq == std::string::npos || it == videos.end()) {
      throw Error("'--calibration': " + text +
                  ": for a dataset input, a calibration belongs to a camera added with --video "
                  "(LABEL=FILE)");
    }
    it->calibration = text.substr(eq + 1);
  }
  return videos;
}

int runMerge(const ConvertArgs& args) {
  MergeOptions options;
  for (const std::string& input : args.merge) options.inputs.push_back(input);
  options.output = args.to;
  options.overwrite = args.overwrite;
  options.on_issue = printDatasetIssue;
  if (const std::string why = options.check(); !why.empty()) throw Error("'--merge': " + why);
  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  try {
    const MergeSummary summary = mergeDatasets(options, progress);
    std::int64_t total = 0;
    for (const auto& [kind, count] : summary.records) total += count;
    std::cout << "wrote " << args.to << ": " << total << " records";
    std::string sep = " (";
    for (const auto& [kind, count] : summary.records) {
      std::cout << sep << kind << ": " << count;
      sep = ", ";
    }
    std::cout << (summary.records.empty() ? "" : ")") << " from " << args.merge.size()
              << " datasets; " << summary.duplicates
              << " records present in several written once\n";
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; " << args.to << " was not written\n";
    return 130;
  }
}

int runConvert(const ConvertArgs& args) {
  if (!args.merge.empty()) {
    if (!args.from.empty()) throw Error("'--merge' and '--from' exclude each other");
    return runMerge(args);
  }
  if (args.from.empty()) throw Error("'--from': required (or --merge A B ...)");
  ConvertOptions options;
  options.from = args.from;
  options.to = args.to;
  options.from_kind = *parseDataKind(args.from_kind);
  options.to_kind = *parseDataKind(args.to_kind);
  options.overwrite = args.overwrite;
  options.strict = args.strict;
  options.trajectory_label = args.label;
  options.trajectory_metric = !args.scaled;
  for (const std::string& t : args.trajectories)
    options.add_trajectories.push_back(parseTrajectoryArg(t));
  options.cameras = args.cameras;
  options.on_issue = printDatasetIssue;
  const ProgressReporter progress(makeConsoleProgress());
  const StopOnSignal stop_on_signal(progress);
  try {
    const auto [from_kind, to_kind] = resolveDataKinds(options);
    if ((from_kind == DataKind::kBag || from_kind == DataKind::kTum || to_kind == DataKind::kTum) &&
        !args.cameras.empty()) {
      throw Error(
          "'--cameras' selects cameras of a dataset; the bag's topic mapping (or a TUM "
          "trajectory) has no use for it");
    }
    if (!args.videos.empty() &&
        (from_kind == DataKind::kBag || from_kind == DataKind::kTum || to_kind == DataKind::kTum)) {
      throw Error(
          "'--video' adds a camera's video to a dataset: convert the bag first (lookboth convert "
          "--from x.mcap --to robot), then add the videos (lookboth convert --from robot --to site "
          "--video cam03=cam03.mp4:start=NS ...)");
    }
    if (from_kind == DataKind::kBag) return runImportBag(args, to_kind, progress);
    options.videos = videoInputs(args);
    const ConvertSummary summary = convertData(options, progress);
    std::cout << "wrote " << args.to << ": " << summary.total() << " records";
    std::string sep = " (";
    for (const auto& [kind, count] : summary.records) {
      std::cout << sep << kind << ": " << count;
      sep = ", ";
    }
    std::cout << (summary.records.empty() ? "" : ")") << "\n";
    const auto warnings = std::count_if(summary.issues.begin(), summary.issues.end(),
                                        [](const DatasetIssue& issue) { return !issue.note; });
    if (warnings > 0) std::cout << warnings << " warning(s), see above\n";
    return 0;
  } catch (const StopRequested&) {
    std::cerr << "lookboth: stopped; " << args.to << " was not written\n";
    return 130;
  }
}

}  // namespace

void registerConvertCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<ConvertArgs>();
  CLI::App* cmd =
      app.add_subcommand("convert",
                         "Convert between dataset layouts (rawlog, folder), TUM trajectories and "
                         "ROS bags (ROS 1 .bag; ROS 2 .mcap, .db3 or a bag folder)");
  const auto kinds = CLI::IsMember({"auto", "rawlog", "folder", "bag", "tum"});
  cmd->add_option("--from", args->from,
                  "Input: x.rawlog (with x.yaml beside it), a folder, x.bag, x.mcap, x.db3, a ROS "
                  "2 bag folder, x.tum");
  cmd->add_option("--to,--out", args->to, "Output: x.rawlog, a folder, or x.tum (a trajectory)")
      ->required();
  cmd->add_option("--merge", args->merge,
                  "Join datasets of one recording (e.g. the shards of `lookboth detect "
                  "--cameras`) into --to: records in time order, shared ones once")
      ->expected(2, -1);
  cmd->add_option("--cameras", args->cameras,
                  "Only these cameras (labels, comma-separated): their frames, detections and "
                  "calibrations, no trajectories; what one camera's edge node holds")
      ->delimiter(',');
  cmd->add_option("--from-kind", args->from_kind, "Force the input kind")->check(kinds);
  cmd->add_option("--to-kind", args->to_kind, "Force the output kind")->check(kinds);
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing output");
  cmd->add_flag("--strict", args->strict,
                "Treat input warnings (duplicates, missing images) as errors");
  cmd->add_option(
      "--label", args->label,
      "Trajectory label: which one to export to TUM, or the label of an imported TUM file");
  cmd->add_flag("--scaled", args->scaled,
                "An imported TUM trajectory is up to scale (monocular VO)");
  cmd->add_option("--trajectory", args->trajectories,
                  "Add a TUM trajectory to the output dataset: FILE.tum=LABEL[:metric|:scaled]");
  cmd->add_option("--topics", args->topics_yaml, "ROS bag: topic mapping YAML (doc/formats.md)")
      ->check(CLI::ExistingFile);
  cmd->add_option(
      "--topic", args->topics,
      "ROS bag: /topic=LABEL:ROLE[:nonmetric][:child=FRAME[:parent=FRAME]] (roles: fisheye, "
      "env_camera, odometry, ground_truth)");
  cmd->add_option("--marker", args->marker, "ROS bag: the robot's marker, DICTIONARY:ID:SIZE_M");
  cmd->add_option("--calibration", args->calibrations,
                  "LABEL=FILE: a ROS bag's calibration overriding CameraInfo, or the "
                  "calibration of a camera added with --video");
  cmd->add_option("--video", args->videos,
                  "A camera's frames from a video file: LABEL=FILE[:start=NS|:times=FILE.csv] "
                  "(the container's times from the first frame's time NS, or a CSV of "
                  "timestamp_ns per frame); a camera the input lacks needs --calibration "
                  "LABEL=FILE");
  cmd->add_flag("--receive-time", args->receive_time,
                "ROS bag: stamp by bag receive time, not header.stamp");
  cmd->callback([args, set_body] { set_body([args] { return runConvert(*args); }); });
}

}  // namespace lookboth::app
