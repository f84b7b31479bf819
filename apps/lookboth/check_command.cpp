// `lookboth check`: a later drive's registration against the one on record,
// camera by camera (doc/formats.md, "Re-checking a facility").
#include <iomanip>
#include <iostream>

#include "commands.h"
#include "lookboth/core/atomic_file.h"
#include "lookboth/core/error.h"
#include "lookboth/core/output_path.h"
#include "lookboth/core/text.h"
#include "lookboth/registration/facility_check.h"
#include "lookboth/registration/registration.h"

namespace lookboth::app {
namespace {

struct CheckArgs {
  std::string registration;
  std::string against;
  std::string update_out;
  bool overwrite = false;
  FacilityCheckOptions options;
};

void printCamera(const CameraCheck& c) {
  std::cout << "  " << std::left << std::setw(12) << c.label << std::setw(11)
            << cameraVerdictName(c.verdict) << std::right;
  if (c.verdict == CameraVerdict::kMoved || c.verdict == CameraVerdict::kUnchanged) {
    std::cout << std::setw(10) << formatFixed(c.moved_m.norm() * 1000, 1) << std::setw(9)
              << formatFixed(std::sqrt(c.position_chi2), 1) << std::setw(10)
              << formatFixed(c.rotated_deg, 3) << std::setw(9)
              << formatFixed(std::sqrt(c.rotation_chi2), 1)
              << (c.used_for_alignment ? "" : "   (left out of the alignment)");
  }
  std::cout << "\n";
}

int runCheck(const CheckArgs& args) {
  if (const std::string why = args.options.check(); !why.empty()) throw Error(why);
  if (!args.update_out.empty()) {
    checkOutputPath(args.update_out, {args.registration, args.against}, args.overwrite);
  }
  // The cameras are compared; the record's blobs are read only to be written
  // again with it (--update-out).
  const Registration fresh = loadRegistration(args.registration, {false});
  const Registration record = loadRegistration(args.against, {!args.update_out.empty()});
  const FacilityCheck check = checkFacility(fresh, record, args.options);
  std::cout << args.registration << " against " << args.against << "\n";
  printFacilityCheck(check, args.options);
  if (!args.update_out.empty()) {
    const Registration updated = updateRegistration(record, fresh, check);
    writeDirectoryAtomically(
        args.update_out, [&](const std::filesystem::path& dir) { saveRegistration(updated, dir); });
    std::cout << "wrote " << args.update_out << ": " << updated.notes.back() << "\n";
  } else if (check.moved + check.added > 0) {
    std::cout << "to update the record with them: --update-out <dir>\n";
  }
  return 0;
}

}  // namespace

void printFacilityCheck(const FacilityCheck& check, const FacilityCheckOptions& options) {
  std::cout << "  camera      verdict     moved [mm]  sigmas  turned [deg]  sigmas\n";
  for (const CameraCheck& c : check.cameras) printCamera(c);
  std::cout << check.moved << " moved, " << check.unchanged << " unchanged, " << check.not_seen
            << " not seen, " << check.added << " new (moved: more than "
            << formatFixed(options.min_position_m * 1000, 1) << " mm or "
            << formatFixed(options.min_rotation_deg, 2)
            << " deg, and beyond both registrations' uncertainty)\n";
}

void addMoveTolerances(CLI::App* cmd, FacilityCheckOptions& options, const std::string& when) {
  cmd->add_option("--min-move-m", options.min_position_m,
                  when + "Smaller position changes are 'unchanged' [m]")
      ->capture_default_str();
  cmd->add_option("--min-turn-deg", options.min_rotation_deg,
                  when + "Smaller rotation changes are 'unchanged' [deg]")
      ->capture_default_str();
}

void registerCheckCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  auto args = std::make_shared<CheckArgs>();
  CLI::App* cmd = app.add_subcommand(
      "check", "Which cameras moved: a later drive's registration against the one on record");
  cmd->add_option("registration", args->registration, "The new drive's registration directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--against", args->against, "The registration on record")
      ->required()
      ->check(CLI::ExistingDirectory);
  addMoveTolerances(cmd, args->options, "");
  cmd->add_option("--update-out", args->update_out,
                  "Write the record updated by this drive here: the moved and new cameras "
                  "take this drive's poses, the others the record's, in the record's frame "
                  "(`register <drive> --update <record>` registers them against the unchanged "
                  "ones instead)");
  cmd->add_flag("--overwrite", args->overwrite, "Replace an existing --update-out");
  cmd->callback([args, set_body] { set_body([args] { return runCheck(*args); }); });
}

}  // namespace lookboth::app
