#include "lookboth/core/option_fields.h"

#include "lookboth/core/error.h"

namespace lookboth {

OptionFields OptionFields::reading(const YamlReader& reader, const YAML::Node& node,
                                   const std::string& field) {
  return OptionFields(&reader, node, field, nullptr);
}

OptionFields OptionFields::writing(YAML::Node& out) {
  // A default-constructed node owns no storage yet: a copy of it would
  // write into storage of its own, not `out`'s.
  if (!out.IsMap()) out = YAML::Node(YAML::NodeType::Map);
  return OptionFields(nullptr, out, "", nullptr);
}

OptionFields OptionFields::listing(std::set<std::string>& keys) {
  return OptionFields(nullptr, YAML::Node(), "", &keys);
}

bool OptionFields::wanted(const char* key) {
  if (keys_) {
    keys_->insert(key);
    return false;
  }
  return !reader_ || node(key);
}

void OptionFields::number(const char* key, double& target) {
  if (!wanted(key)) return;
  if (reader_) {
    target = reader_->number(node(key), path(key));
  } else {
    node_[key] = target;
  }
}

void OptionFields::integer(const char* key, int& target) {
  if (!wanted(key)) return;
  if (reader_) {
    target = reader_->int32(node(key), path(key));
  } else {
    node_[key] = target;
  }
}

void OptionFields::unsigned32(const char* key, std::uint32_t& target) {
  if (!wanted(key)) return;
  if (!reader_) {
    node_[key] = target;
    return;
  }
  const long long value = reader_->integer(node(key), path(key));
  if (value < 0 || value > 4294967295LL) {
    throw Error(reader_->at(node(key), path(key)), "must be in [0, 4294967295]");
  }
  target = static_cast<std::uint32_t>(value);
}

void OptionFields::flag(const char* key, bool& target) {
  if (!wanted(key)) return;
  if (reader_) {
    target = reader_->boolean(node(key), path(key));
  } else {
    node_[key] = target;
  }
}

void OptionFields::text(const char* key, std::string& target) {
  if (!wanted(key)) return;
  if (reader_) {
    target = reader_->text(node(key), path(key));
  } else {
    node_[key] = target;
  }
}

template <typename Value, typename Read>
void OptionFields::byLabel(const char* key, std::map<std::string, Value>& target, const char* form,
                           Read read) {
  if (!wanted(key)) return;
  if (!reader_) {
    YAML::Node map(YAML::NodeType::Map);
    for (const auto& [label, value] : target) map[label] = value;
    node_[key] = map;
    return;
  }
  const YAML::Node entries = node(key);
  if (entries.IsNull()) return;
  if (!entries.IsMap())
    throw Error(reader_->at(entries, path(key)), std::string("expected a mapping ") + form);
  for (const auto& entry : entries) {
    const std::string label = reader_->key(entry.first, path(key));
    target[label] = read(entry.second, path(key) + "." + label);
  }
}

void OptionFields::integers(const char* key, std::map<std::string, std::int64_t>& target,
                            const char* form) {
  byLabel(key, target, form, [this](const YAML::Node& n, const std::string& field) {
    return static_cast<std::int64_t>(reader_->integer(n, field));
  });
}

void OptionFields::numbersByLabel(const char* key, std::map<std::string, double>& target,
                                  const char* form) {
  byLabel(key, target, form, [this](const YAML::Node& n, const std::string& field) {
    return reader_->number(n, field);
  });
}

bool OptionFields::numbers(const char* key, std::vector<double>& values, const char* expected,
                           bool* present) {
  if (!wanted(key)) return false;
  if (!reader_) {
    if (present && !*present) {
      node_[key] = YAML::Node(YAML::NodeType::Null);
    } else {
      node_[key] = values;
    }
    return true;
  }
  const YAML::Node n = node(key);
  if (present && n.IsNull()) {
    *present = false;
    return true;
  }
  if (!n.IsSequence() || n.size() != values.size()) {
    throw Error(reader_->at(n, path(key)), std::string("expected ") + expected);
  }
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = reader_->number(n[i], path(key));
  if (present) *present = true;
  return true;
}

namespace {

std::string flow(const YAML::Node& node) {
  if (!node.IsDefined()) return "(absent)";
  YAML::Emitter out;
  out << YAML::Flow << node;
  return out.c_str();
}

}  // namespace

std::vector<std::string> optionDifferences(const YAML::Node& a, const YAML::Node& b,
                                           const std::string& field) {
  std::vector<std::string> found;
  std::set<std::string> keys;
  for (const YAML::Node& side : {a, b}) {
    if (!side.IsMap()) continue;
    for (const auto& entry : side) keys.insert(entry.first.as<std::string>());
  }
  // In a's order first (the order of the fields), then b's others.
  std::vector<std::string> ordered;
  if (a.IsMap()) {
    for (const auto& entry : a) ordered.push_back(entry.first.as<std::string>());
  }
  for (const std::string& key : keys) {
    if (!a.IsMap() || !a[key]) ordered.push_back(key);
  }
  for (const std::string& key : ordered) {
    const YAML::Node x = a.IsMap() ? a[key] : YAML::Node(), y = b.IsMap() ? b[key] : YAML::Node();
    if (x.IsMap() && y.IsMap()) {
      const std::vector<std::string> inner = optionDifferences(x, y, field + "." + key);
      found.insert(found.end(), inner.begin(), inner.end());
    } else if (flow(x) != flow(y)) {
      found.push_back(field + "." + key + ": " + flow(x) + " against " + flow(y));
    }
  }
  return found;
}

}  // namespace lookboth
