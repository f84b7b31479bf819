// One list of an options struct's keys serves three ways. The struct's
// module writes, once, a function
//   void fields(MyOptions& o, OptionFields& f) { f.number("gate_px", o.gate_px); ... }
// and OptionFields runs it
//   - reading a configuration section over the current values (a key sets
//     its value only when present; readOptions rejects unknown keys, naming
//     the file, line and field);
//   - writing every value under its key (writeOptions: the effective
//     configuration, and the tests that share/lookboth/config/default.yaml
//     says what the compiled defaults say);
//   - listing the keys.
// (MRPT's TConfigParams load and save themselves the same way.)
#pragma once
#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "lookboth/core/yaml_reader.h"

namespace lookboth {

class OptionFields {
 public:
  static OptionFields reading(const YamlReader& reader, const YAML::Node& node,
                              const std::string& field);
  static OptionFields writing(YAML::Node& out);
  static OptionFields listing(std::set<std::string>& keys);

  void number(const char* key, double& target);  ///< finite
  void integer(const char* key, int& target);
  void unsigned32(const char* key, std::uint32_t& target);
  void flag(const char* key, bool& target);
  void text(const char* key, std::string& target);
  /// A mapping label: integer (e.g. clock offsets by camera); `form` shows
  /// it in errors ("label: ns").
  void integers(const char* key, std::map<std::string, std::int64_t>& target,
                const char* form = "label: integer");
  /// A mapping label: number (e.g. fixed markers' sizes by id); `form` shows
  /// it in errors ("id: size_m").
  void numbersByLabel(const char* key, std::map<std::string, double>& target,
                      const char* form = "label: number");
  /// A list of exactly `values.size()` numbers; `expected` shows its form in
  /// errors ("[x, y, z]"). With `optional`, null (or ~) clears it: the return
  /// is then false (and `values` untouched) when the key is null.
  bool numbers(const char* key, std::vector<double>& values, const char* expected,
               bool* present = nullptr);

  /// "<field>.<key>", for errors of the struct's own checks.
  std::string path(const char* key) const { return field_ + "." + key; }
  /// The reader and the node of a key being read (for a check of its own
  /// that names the line); only while reading. A const lookup: an absent
  /// key is not added to the configuration being read.
  const YamlReader& reader() const { return *reader_; }
  YAML::Node node(const char* key) const { return node_[key]; }
  bool isReading() const { return reader_ != nullptr; }

 private:
  /// A mapping label: value, each value read by `read(node, field)`.
  template <typename Value, typename Read>
  void byLabel(const char* key, std::map<std::string, Value>& target, const char* form, Read read);
  OptionFields(const YamlReader* reader, YAML::Node node, std::string field,
               std::set<std::string>* keys)
      : reader_(reader), node_(node), field_(std::move(field)), keys_(keys) {}
  /// Whether `key` is to be read or written (listing records it and says no).
  bool wanted(const char* key);

  const YamlReader* reader_;  ///< null when writing or listing
  YAML::Node node_;
  std::string field_;
  std::set<std::string>* keys_;  ///< set when listing
};

/// Reads `node` (named `field` in errors) into `options` through
/// fields(options, OptionFields&): unknown keys are errors.
template <typename Options>
void readOptions(Options& options, const YamlReader& reader, const YAML::Node& node,
                 const std::string& field) {
  std::set<std::string> keys;
  OptionFields listing = OptionFields::listing(keys);
  fields(options, listing);
  reader.rejectUnknownKeys(node, keys, field);
  OptionFields read = OptionFields::reading(reader, node, field);
  fields(options, read);
}

/// Every value of `options` under its key, as readOptions reads them.
template <typename Options>
void writeOptions(const Options& options, YAML::Node& out) {
  OptionFields write = OptionFields::writing(out);
  Options copy = options;  // fields() takes the options to fill; writing only reads them
  fields(copy, write);
}

/// The keys whose values differ between two written sections (nested
/// mappings compared key by key), each as "<field>.<key>: <a> against <b>";
/// a key only one side has is listed too.
std::vector<std::string> optionDifferences(const YAML::Node& a, const YAML::Node& b,
                                           const std::string& field);

}  // namespace lookboth
