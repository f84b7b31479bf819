#include "lookboth/core/yaml_reader.h"

#include <cmath>
#include <limits>
#include <map>

#include "lookboth/core/text.h"

namespace lookboth {

YAML::Node YamlReader::parse(const std::string& text) const {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw Error({source_, e.mark.line + 1, "", ""}, "not valid YAML: " + e.msg);
  }
}

ErrorContext YamlReader::at(const YAML::Node& node, const std::string& field) const {
  return {source_, node.IsDefined() ? static_cast<int>(node.Mark().line) + 1 : 0, field, ""};
}

YAML::Node YamlReader::require(const YAML::Node& parent, const std::string& key,
                               const std::string& field) const {
  const YAML::Node node = parent[key];
  if (!node.IsDefined() || node.IsNull()) throw Error(at(parent, field), "missing");
  return node;
}

double YamlReader::number(const YAML::Node& node, const std::string& field) const {
  if (!node.IsScalar()) throw Error(at(node, field), "expected a number");
  const auto value = parseDouble(node.Scalar());
  if (!value || !std::isfinite(*value)) {
    throw Error(at(node, field), excerpt(node.Scalar()) + " is not a finite number");
  }
  return *value;
}

long long YamlReader::integer(const YAML::Node& node, const std::string& field) const {
  if (!node.IsScalar()) throw Error(at(node, field), "expected an integer");
  const auto value = parseInt(node.Scalar());
  if (!value) throw Error(at(node, field), excerpt(node.Scalar()) + " is not an integer");
  return *value;
}

int YamlReader::int32(const YAML::Node& node, const std::string& field) const {
  const long long value = integer(node, field);
  if (value < std::numeric_limits<int>::min() || value > std::numeric_limits<int>::max()) {
    throw Error(at(node, field), excerpt(node.Scalar()) + " is out of range");
  }
  return static_cast<int>(value);
}

void YamlReader::checkConfigRoot(const YAML::Node& root, const std::string& text) const {
  if (!root.IsDefined() || root.IsNull()) {
    const bool blank = text.find_first_not_of(" \t\r\n") == std::string::npos;
    throw Error(ErrorContext{source_, 0, "", ""},
                blank ? "the configuration file is empty (nothing to apply)"
                      : "the configuration file holds no section (only comments?); expected "
                        "register:, odometry: or detect:");
  }
  if (!root.IsMap()) {
    throw Error(at(root, ""), "expected a mapping of sections (register:, odometry:, detect:)");
  }
  rejectUnknownKeys(root, kConfigSections, "");
}

std::string YamlReader::text(const YAML::Node& node, const std::string& field) const {
  if (!node.IsScalar()) throw Error(at(node, field), "expected text");
  return node.Scalar();
}

bool YamlReader::boolean(const YAML::Node& node, const std::string& field) const {
  const std::string value = text(node, field);
  if (value == "true" || value == "yes") return true;
  if (value == "false" || value == "no") return false;
  throw Error(at(node, field), "expected true or false, got " + excerpt(value));
}

std::string YamlReader::key(const YAML::Node& key_node, const std::string& field) const {
  // yaml-cpp gives an entry of a list an invalid key node, whose every
  // question but IsDefined() throws: the caller iterated a list as a mapping.
  if (!key_node.IsDefined()) throw Error(at(key_node, field), "expected a mapping, not a list");
  if (!key_node.IsScalar()) throw Error(at(key_node, field), "expected a text key");
  return key_node.Scalar();
}

void YamlReader::rejectUnknownKeys(const YAML::Node& node, const std::set<std::string>& known,
                                   const std::string& field) const {
  if (!node.IsMap()) throw Error(at(node, field), "expected a mapping");
  // yaml-cpp keeps a repeated key and answers node[key] with the first one:
  // the second would be silently ignored.
  std::map<std::string, int> first_line;
  for (const auto& entry : node) {
    const std::string key = this->key(entry.first, field);
    const int line = entry.first.Mark().line + 1;
    if (const auto [it, inserted] = first_line.emplace(key, line); !inserted) {
      throw Error(at(entry.first, field.empty() ? key : field + "." + key),
                  "duplicate key (first at line " + std::to_string(it->second) + ")");
    }
    if (!known.count(key)) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw Error(at(entry.first, field.empty() ? key : field + "." + key),
                  "unknown key (known: " + list + ")");
    }
  }
}

}  // namespace lookboth
