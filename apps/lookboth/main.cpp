// lookboth: registration of a network of fixed cameras with a robot that
// looks both ways. One binary, one subcommand per job (see `lookboth --help`).
// Exit codes: 0 success, 1 bad input data (lookboth::Error), 2 usage error,
// 3 internal error.
#include <clocale>
#include <filesystem>
#include <iostream>
#include <new>

#include "commands.h"
#include "lookboth/core/error.h"

int main(int argc, char** argv) {
  // Numbers are read and written with a decimal point whatever the user's locale.
  std::setlocale(LC_NUMERIC, "C");

  CLI::App app{
      "lookboth: register a network of fixed, ceiling-mounted cameras with a robot that "
      "carries an upward fisheye and a backlit marker."};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Help for every subcommand");

  lookboth::app::CommandBody body;
  const auto set_body = [&body](lookboth::app::CommandBody b) { body = std::move(b); };
  lookboth::app::registerVersionCommand(app, set_body);
  lookboth::app::registerCameraCommands(app, set_body);
  lookboth::app::registerConvertCommand(app, set_body);
  lookboth::app::registerSimulateCommand(app, set_body);
  lookboth::app::registerDetectCommand(app, set_body);
  lookboth::app::registerRegisterCommand(app, set_body);
  lookboth::app::registerOdometryCommand(app, set_body);
  lookboth::app::registerEvaluateCommand(app, set_body);
  lookboth::app::registerSnapshotCommand(app, set_body);
  lookboth::app::registerReportCommand(app, set_body);
  lookboth::app::registerAlignCommand(app, set_body);
  lookboth::app::registerCheckCommand(app, set_body);
  lookboth::app::registerExportCommand(app, set_body);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; any usage error exits 2.
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    return body ? body() : 0;
  } catch (const lookboth::Error& e) {
    std::cerr << "lookboth: error: " << e.what() << "\n";
    return 1;
  } catch (const std::filesystem::filesystem_error& e) {
    // A read-only folder, a full disk, a missing permission: the user's to fix.
    std::cerr << "lookboth: error: " << lookboth::app::describeFilesystemError(e) << "\n";
    return 1;
  } catch (const std::bad_alloc&) {
    std::cerr << "lookboth: error: out of memory\n";
    return 1;
  } catch (const std::exception& e) {
    std::cerr << "lookboth: internal error: " << e.what() << "\n";
    return 3;
  }
}
