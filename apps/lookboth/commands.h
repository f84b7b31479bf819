// The subcommands of the `lookboth` command line. Each family registers its
// subcommands on the CLI11 app; each subcommand parses and validates its own
// options, then calls the libraries. No estimation logic lives here.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <string>

#include "lookboth/dataset/dataset_io.h"
#include "lookboth/registration/facility_check.h"

namespace lookboth::app {

/// A subcommand's body; returns the process exit code. Exceptions of type
/// lookboth::Error are caught by main and printed as "lookboth: error: ...".
using CommandBody = std::function<int()>;

/// Called once per family from main; `set_body` records what to run when the
/// user picked one of the family's subcommands.
void registerVersionCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerCameraCommands(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerConvertCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerSimulateCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerDetectCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerRegisterCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerOdometryCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerEvaluateCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerSnapshotCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerReportCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerCheckCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerAlignCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);
void registerExportCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body);

/// Prints an input issue on stderr: "lookboth: warning: <where>: <message>",
/// or "lookboth: note: ..." for a note (nothing skipped).
void printDatasetIssue(const DatasetIssue& issue);

/// The tolerances of a facility check (`check`, `report --record`):
/// --min-move-m and --min-turn-deg, their help starting with `when`.
void addMoveTolerances(CLI::App* cmd, FacilityCheckOptions& options, const std::string& when);
/// `check`'s table: one row per camera (verdict, moved mm and sigmas, turned
/// deg and sigmas) and the counts, on stdout.
void printFacilityCheck(const FacilityCheck& check, const FacilityCheckOptions& options);

/// "cannot write 'path': No space left on device" for a failed file operation.
std::string describeFilesystemError(const std::filesystem::filesystem_error& e);

}  // namespace lookboth::app
