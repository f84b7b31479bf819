// Strict reading of YAML configuration and manifests: every error names the
// file (`source`), the line and the dotted field path, numbers are parsed
// without the locale, and unknown keys are errors (a typo must not be
// silently ignored).
#pragma once

#include <yaml-cpp/yaml.h>

#include <set>
#include <string>

#include "lookboth/core/error.h"

namespace lookboth {

class YamlReader {
 public:
  /// `source` names the document in errors (usually its path).
  explicit YamlReader(std::string source) : source_(std::move(source)) {}

  /// Parses text; a syntax error names the source and line.
  YAML::Node parse(const std::string& text) const;

  const std::string& source() const { return source_; }
  /// Context of a node for errors: source, 1-based line, field path.
  ErrorContext at(const YAML::Node& node, const std::string& field) const;

  /// parent[key]; throws "missing" naming `field` when absent or null.
  YAML::Node require(const YAML::Node& parent, const std::string& key,
                     const std::string& field) const;

  double number(const YAML::Node& node, const std::string& field) const;  ///< finite
  long long integer(const YAML::Node& node, const std::string& field) const;
  std::string text(const YAML::Node& node, const std::string& field) const;
  bool boolean(const YAML::Node& node, const std::string& field) const;  ///< true/false/yes/no

  /// Throws naming the first key of a mapping that is not in `known` (and
  /// listing the known ones), or that appears twice.
  void rejectUnknownKeys(const YAML::Node& node, const std::set<std::string>& known,
                         const std::string& field) const;

 private:
  std::string source_;
};

}  // namespace lookboth
