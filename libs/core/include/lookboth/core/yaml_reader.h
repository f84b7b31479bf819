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

/// The sections of a lookboth configuration file (share/lookboth/config/default.yaml).
inline const std::set<std::string> kConfigSections = {"register", "odometry", "detect"};

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
  /// An integer that fits an int (a larger one is an error, not a wrapped value).
  int int32(const YAML::Node& node, const std::string& field) const;
  std::string text(const YAML::Node& node, const std::string& field) const;
  bool boolean(const YAML::Node& node, const std::string& field) const;  ///< true/false/yes/no

  /// A mapping's key as text; a key that is itself a list or a mapping
  /// (`? [a, b]: 1`, legal YAML) is an error naming `field` and its line.
  std::string key(const YAML::Node& key_node, const std::string& field) const;

  /// Throws naming the first key of a mapping that is not in `known` (and
  /// listing the known ones), or that appears twice.
  void rejectUnknownKeys(const YAML::Node& node, const std::set<std::string>& known,
                         const std::string& field) const;

  /// Checks the top level of a lookboth configuration file (`text` parsed as
  /// `root`): a mapping whose keys are among kConfigSections. A misspelled
  /// section ("registr:") or an empty file would otherwise be ignored, and
  /// the run would use the defaults without a word.
  void checkConfigRoot(const YAML::Node& root, const std::string& text) const;

 private:
  std::string source_;
};

}  // namespace lookboth
