// `lookboth align`: a registration re-expressed in the floor's frame or in
// the site's (surveyed control points); doc/formats.md, "Site frame".
#include <algorithm>
#include <cmath>
#include <iostream>

#include "commands.h"
#include "lookboth/calib/fixed_markers.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/dataset_io.h"
#include "lookboth/registration/registration.h"
#include "lookboth/registration/site_frame.h"

namespace lookboth::app {
namespace {

struct AlignArgs {
  std::string registration;
  std::string control_points;
  bool floor = false;
  std::string out;
  std::string dataset;
  bool overwrite = false;
  SiteAlignmentOptions site;
};

/// The fixed markers the control points name ("marker:<id>"), located from
/// the registered dataset's detections; none read when no point names one.
LocatedPoints fixedMarkers(const Registration& reg, const AlignArgs& args) {
  const std::vector<ControlPoint> points = readControlPoints(args.control_points);
  const bool any = std::any_of(points.begin(), points.end(),
                               [](const ControlPoint& p) { return namesFixedMarker(p.name); });
  if (!any) return {};
  const std::filesystem::path dataset = args.dataset.empty() ? reg.dataset : args.dataset;
  if (!std::filesystem::exists(dataset)) {
    throw Error({dataset.string(), 0, "", ""},
                "the registered dataset is not there (its detections locate the markers the "
                "control points name); name it with --dataset");
  }
  const MarkerDetections read = readMarkerDetections(dataset);
  const LocatedPoints located = locateFixedMarkers(reg, read.detections, read.manifest.marker.id);
  for (const auto& [name, point] : located) {
    std::cout << name << ": located from " << point.detections << " detections, sigma "
              << formatFixed(std::sqrt(point.covariance.trace() / 3) * 1000, 1) << " mm\n";
  }
  return located;
}

int runAlign(const AlignArgs& args) {
  if (args.floor == !args.control_points.empty()) {
    throw Error("align: give either --floor or --control-points");
  }
  std::vector<std::filesystem::path> inputs = {args.registration};
  if (!args.control_points.empty()) inputs.emplace_back(args.control_points);
  checkOutputPath(args.out, inputs, args.overwrite);
  const Registration reg = loadRegistration(args.registration);
  const AlignedRegistration aligned =
      args.floor ? alignRegistrationToFloor(reg)
                 : alignRegistrationToControlPoints(reg, args.control_points, args.site,
                                                    fixedMarkers(reg, args));
  for (const std::string& line : aligned.summary) std::cout << line << "\n";
  writeDirectoryAtomically(args.out, [&](const std::filesystem::path& dir) {
    saveRegistration(aligned.registration, dir);
  });
  std::cout << "wrote " << args.out << " (world frame '" << aligned.registration.world_frame.name
            << "')\n";
  return 0;
}

}  // namespace

void registerAlignCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<AlignArgs>();
  CLI::App* cmd = app.add_subcommand(
      "align", "A registration in the floor's frame or the site's (surveyed control points)");
  cmd->add_option("registration", args->registration, "Registration directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_flag("--floor", args->floor,
                "z normal to the floor the robot drove on, origin at its first pose");
  cmd->add_option("--control-points", args->control_points,
                  "CSV name,x,y,z,sigma_m: registered cameras' positions in the site's frame [m]; "
                  "a name @start, @end or @<unix seconds> is the fisheye's position on the "
                  "trajectory then (the robot's dock), marker:<id> a marker fixed in the "
                  "facility that the cameras detected")
      ->check(CLI::ExistingFile);
  cmd->add_option("--dataset", args->dataset,
                  "The dataset registered, whose detections locate the markers named "
                  "marker:<id> (default: the one registration.yaml names)");
  cmd->add_flag("--with-scale", args->site.with_scale,
                "With --control-points: a similarity (Sim(3)), the scale from the points too "
                "(at least 4)");
  cmd->add_option("--out", args->out, "The registration directory to write")->required();
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing --out");
  cmd->callback([args, set_body] { set_body([args] { return runAlign(*args); }); });
}

}  // namespace lookboth::app
