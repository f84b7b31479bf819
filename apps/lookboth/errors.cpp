// How main reports what is not a lookboth::Error but still the user's to fix.
#include <iostream>

#include "commands.h"

namespace lookboth::app {

void printDatasetIssue(const DatasetIssue& issue) {
  std::cerr << "lookboth: " << (issue.note ? "note: " : "warning: ") << issue.where << ": "
            << issue.message << "\n";
}

std::string describeFilesystemError(const std::filesystem::filesystem_error& e) {
  std::string where;
  if (!e.path1().empty()) where = "'" + e.path1().string() + "'";
  if (!e.path2().empty()) where += (where.empty() ? "'" : " -> '") + e.path2().string() + "'";
  std::string message = e.code().message();
  if (e.code() == std::errc::no_space_on_device) message += " (free some space and run again)";
  if (e.code() == std::errc::permission_denied || e.code() == std::errc::read_only_file_system)
    message += " (choose a folder you can write to)";
  return (where.empty() ? std::string("file operation failed") : "cannot write or read " + where) +
         ": " + message;
}

}  // namespace lookboth::app
