// Private to libs/dataset: a small streaming CSV reader for the folder
// format (header row with named columns, '#' comment lines, line numbers in
// every error) and a writer.
#pragma once

#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/core/error.h"

namespace lookboth::internal {

class CsvReader {
 public:
  /// Opens the file and reads the header. `required` columns must be
  /// present (an error names the file, line 1 and the missing column);
  /// other columns may be present and are ignored unless asked for.
  CsvReader(const std::filesystem::path& path, const std::vector<std::string>& required);

  /// Advances to the next data row; false at the end of the file. Blank and
  /// '#' lines are skipped. A row with fewer fields than the header is an error.
  bool next();

  bool hasColumn(const std::string& name) const;
  /// The raw text of a column in the current row.
  const std::string& text(const std::string& column) const;
  /// Parsed values; errors name file, line and column ("not a number", "NaN").
  double number(const std::string& column) const;
  long long integer(const std::string& column) const;

  /// Context for errors about the current row.
  ErrorContext where(const std::string& column = "") const;
  int line() const { return line_; }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::ifstream in_;
  std::map<std::string, size_t> columns_;
  std::vector<std::string> fields_;
  int line_ = 0;
};

/// Splits one CSV line on commas (no quoting: the folder format has none).
std::vector<std::string> splitCsvLine(const std::string& line);

}  // namespace lookboth::internal
