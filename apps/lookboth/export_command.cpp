// `lookboth export`: a registration in the formats the systems downstream
// read (doc/formats.md, "Exports"), the intrinsics from the dataset that was
// registered.
#include <algorithm>
#include <iostream>

#include "commands.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/export/export.h"
#include "lookboth/registration/registration.h"

namespace lookboth::app {
namespace {

struct ExportArgs {
  std::string registration;
  std::string formats;
  std::string out;
  std::string dataset;
  std::string world_frame = "site";
  bool include_suspect = false;
  bool overwrite = false;
};

std::vector<ExportFormat> parseFormats(const std::string& text) {
  try {
    return parseExportFormats(text);
  } catch (const Error& e) {
    throw Error(std::string("--format: ") + e.what());
  }
}

int runExport(const ExportArgs& args) {
  const std::vector<ExportFormat> formats = parseFormats(args.formats);
  ExportOptions options;
  options.include_suspect = args.include_suspect;
  options.world_frame = args.world_frame;
  if (const std::string why = options.check(); !why.empty()) throw Error("--world-frame: " + why);
  const Registration registration = loadRegistration(args.registration);
  const std::filesystem::path dataset =
      std::filesystem::path(args.dataset.empty() ? registration.dataset : args.dataset);
  checkOutputPath(args.out, {args.registration, dataset}, args.overwrite);
  const bool graph =
      std::find(formats.begin(), formats.end(), ExportFormat::kMrpt) != formats.end();
  const ExportSources sources = readExportSources(dataset, graph);

  const std::vector<std::string> lines =
      exportRegistrationFormats(registration, sources, args.out, formats, options);
  for (const std::string& line : lines) std::cout << line << "\n";
  std::cout << "wrote " << args.out << "\n";
  return 0;
}

}  // namespace

void registerExportCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<ExportArgs>();
  CLI::App* cmd = app.add_subcommand(
      "export",
      "A registration for other systems: COLMAP, JSON, OpenCV YAML per camera, ROS 2, MRPT");
  cmd->add_option("registration", args->registration, "Registration directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option(
         "--format", args->formats,
         "colmap (text model), json (registration.json), opencv (<camera>.yaml each), "
         "ros (URDF, static transforms, camera_info), mrpt (pose graph); several separated "
         "by commas, "
         "or all (one folder each)")
      ->required();
  cmd->add_option("--out", args->out, "The folder to write")->required();
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing --out");
  cmd->add_option("--dataset", args->dataset,
                  "The dataset registered, for the intrinsics and, in MRPT's graph, the "
                  "detections (default: the one registration.yaml names)");
  cmd->add_flag("--include-suspect", args->include_suspect,
                "Also export the cameras marked suspect (their status is written with them)");
  cmd->add_option("--world-frame", args->world_frame,
                  "ros: the name of the registration's frame, the URDF's root link")
      ->capture_default_str();
  cmd->callback([args, set_body] { set_body([args] { return runExport(*args); }); });
}

}  // namespace lookboth::app
