#include "csv.h"

#include <algorithm>
#include <cmath>

#include "lookboth/core/text.h"

namespace lookboth::internal {

namespace {

std::string trimmed(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

/// Blank lines and '#' lines carry no data.
bool isCommentOrBlank(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r\n");
  return first == std::string::npos || line[first] == '#';
}

std::string joined(const std::vector<std::string>& names) {
  std::string list;
  for (const std::string& name : names) list += (list.empty() ? "" : ",") + name;
  return "'" + list + "'";
}

}  // namespace

std::vector<std::string> splitCsvLine(const std::string& line) {
  std::vector<std::string> fields;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    if (comma == std::string::npos) {
      fields.push_back(trimmed(line.substr(start)));
      break;
    }
    fields.push_back(trimmed(line.substr(start, comma - start)));
    start = comma + 1;
  }
  return fields;
}

CsvReader::CsvReader(const std::filesystem::path& path, const std::vector<std::string>& required)
    : path_(path), in_(path) {
  if (!in_) throw Error({path_.string(), 0, "", ""}, "cannot open for reading");
  std::string line;
  while (std::getline(in_, line)) {
    ++line_;
    // A byte-order mark (spreadsheet programs write one) is not part of the
    // first column's name.
    if (line_ == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);
    if (isCommentOrBlank(line)) continue;
    const std::vector<std::string> names = splitCsvLine(line);
    for (size_t i = 0; i < names.size(); ++i) {
      if (names[i].empty()) continue;  // e.g. a trailing comma
      if (!columns_.emplace(names[i], i).second) {
        throw Error({path_.string(), line_, excerpt(names[i]), ""},
                    "column appears twice in the header");
      }
    }
    break;
  }
  if (columns_.empty()) {
    throw Error({path_.string(), 0, "", ""},
                "no header line (expected the columns " + joined(required) + ")");
  }
  for (const std::string& name : required) {
    if (!hasColumn(name)) {
      throw Error({path_.string(), line_, name, ""},
                  "required column is missing from the header (expected at least " +
                      joined(required) + ")");
    }
  }
}

bool CsvReader::next() {
  if (!in_.is_open()) return false;
  std::string line;
  while (std::getline(in_, line)) {
    ++line_;
    if (isCommentOrBlank(line)) continue;
    fields_ = splitCsvLine(line);
    size_t needed = 0;
    for (const auto& [name, index] : columns_) needed = std::max(needed, index + 1);
    if (fields_.size() < needed) {
      throw Error({path_.string(), line_, "", ""},
                  "expected " + std::to_string(needed) +
                      " comma-separated fields as in the header, got " +
                      std::to_string(fields_.size()));
    }
    return true;
  }
  in_.close();
  fields_.clear();
  return false;
}

bool CsvReader::hasColumn(const std::string& name) const { return columns_.count(name) > 0; }

const std::string& CsvReader::text(const std::string& column) const {
  const auto found = columns_.find(column);
  if (found == columns_.end()) throw Error(where(column), "no such column in the header");
  if (found->second >= fields_.size()) throw Error(where(column), "no current row");
  return fields_[found->second];
}

double CsvReader::number(const std::string& column) const {
  const std::string& value = text(column);
  if (value.empty()) throw Error(where(column), "empty field, expected a number");
  const std::optional<double> parsed = parseDouble(value);
  if (!parsed) throw Error(where(column), "not a number: " + excerpt(value));
  if (std::isnan(*parsed)) throw Error(where(column), "NaN is not allowed");
  if (!std::isfinite(*parsed))
    throw Error(where(column), "infinite value " + excerpt(value) + " is not allowed");
  return *parsed;
}

long long CsvReader::integer(const std::string& column) const {
  const std::string& value = text(column);
  if (value.empty()) throw Error(where(column), "empty field, expected an integer");
  const std::optional<long long> parsed = parseInt(value);
  if (!parsed) throw Error(where(column), "not an integer: " + excerpt(value));
  return *parsed;
}

ErrorContext CsvReader::where(const std::string& column) const {
  return ErrorContext{path_.string(), line_, column, ""};
}

}  // namespace lookboth::internal
