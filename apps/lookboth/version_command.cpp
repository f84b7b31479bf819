#include <iostream>

#include "commands.h"
#include "lookboth/core/version.h"

namespace lookboth::app {

void registerVersionCommand(CLI::App& app, const std::function<void(CommandBody)>& set_body) {
  CLI::App* cmd =
      app.add_subcommand("version", "Print the version and the libraries lookboth was built with");
  app.set_version_flag("--version", std::string("lookboth ") + versionString());
  cmd->callback([set_body] {
    set_body([] {
      std::cout << buildInfo();
      return 0;
    });
  });
}

}  // namespace lookboth::app
