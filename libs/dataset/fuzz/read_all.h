// Reads a whole dataset the way `lookboth convert` does, issues as warnings.
#pragma once

#include <filesystem>

#include "lookboth/dataset/dataset_io.h"

namespace lookboth::fuzz {

inline void readWholeDataset(const std::filesystem::path& path) {
  DatasetReadOptions options;
  options.on_issue = [](const DatasetIssue&) {};
  const auto reader = DatasetReader::open(path, options);
  (void)reader->manifest().check();
  (void)manifestToYaml(reader->manifest());
  while (reader->next()) {
  }
}

}  // namespace lookboth::fuzz
