#include "lookboth/core/yaml_reader.h"

#include <gtest/gtest.h>

namespace lookboth {
namespace {

std::string errorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(YamlReader, ReadsValuesStrictly) {
  const YamlReader r("cfg.yaml");
  const YAML::Node root = r.parse("a: 1.5\nb: 7\nc: yes\nd: text\n");
  EXPECT_EQ(r.number(root["a"], "a"), 1.5);
  EXPECT_EQ(r.integer(root["b"], "b"), 7);
  EXPECT_TRUE(r.boolean(root["c"], "c"));
  EXPECT_EQ(r.text(root["d"], "d"), "text");
  EXPECT_NO_THROW(r.rejectUnknownKeys(root, {"a", "b", "c", "d"}, ""));
}

TEST(YamlReader, ErrorsNameSourceLineAndField) {
  const YamlReader r("cfg.yaml");
  const YAML::Node root = r.parse("a: 1.5\nnested:\n  b: x\n  c: .nan\n");
  EXPECT_EQ(errorOf([&] { r.number(root["nested"]["b"], "nested.b"); }),
            "cfg.yaml:3: 'nested.b': 'x' is not a finite number");
  EXPECT_EQ(errorOf([&] { r.number(root["nested"]["c"], "nested.c"); }),
            "cfg.yaml:4: 'nested.c': '.nan' is not a finite number");
  EXPECT_EQ(errorOf([&] { r.require(root["nested"], "z", "nested.z"); }),
            "cfg.yaml:3: 'nested.z': missing");
  EXPECT_EQ(errorOf([&] { r.integer(root["a"], "a"); }),
            "cfg.yaml:1: 'a': '1.5' is not an integer");
  EXPECT_EQ(errorOf([&] { r.rejectUnknownKeys(root, {"a"}, ""); }),
            "cfg.yaml:2: 'nested': unknown key (known: a)");
  EXPECT_EQ(errorOf([&] { r.parse("a: [1\n"); }).rfind("cfg.yaml:", 0), 0u);
}

TEST(YamlReader, RejectsARepeatedKey) {
  const YamlReader r("cfg.yaml");
  const YAML::Node root = r.parse("s:\n  a: 1\n  b: 2\n  a: 3\n");
  EXPECT_EQ(errorOf([&] {
              r.rejectUnknownKeys(root["s"], {"a", "b"}, "s");
            }),
            "cfg.yaml:4: 's.a': duplicate key (first at line 2)");
}

// Legal YAML, found by the manifest fuzz target: yaml-cpp's own conversion
// of such a key throws its exception, not a lookboth::Error.
TEST(YamlReader, AKeyThatIsNotTextIsAnError) {
  const YamlReader r("m.yaml");
  const YAML::Node root = r.parse("s:\n  a: 1\n  ? [x, y]\n  : 2\n");
  EXPECT_EQ(errorOf([&] { r.rejectUnknownKeys(root["s"], {"a"}, "s"); }),
            "m.yaml:3: 's': expected a text key");
  const YAML::Node map_key = r.parse("{a: 1}: 2\n");
  for (const auto& entry : map_key) {
    EXPECT_EQ(errorOf([&] { r.key(entry.first, "labels"); }),
              "m.yaml:1: 'labels': expected a text key");
  }
}

// Found by the manifest fuzz target: a list where a mapping was expected
// gives entries whose key yaml-cpp marks invalid; any question but
// IsDefined() about it throws yaml-cpp's exception.
TEST(YamlReader, AListIteratedAsAMappingIsAnError) {
  const YamlReader r("m.yaml");
  const YAML::Node root = r.parse("labels:\n  - cam03\n");
  for (const auto& entry : root["labels"]) {
    EXPECT_EQ(errorOf([&] { r.key(entry.first, "labels"); }),
              "m.yaml: 'labels': expected a mapping, not a list");
  }
}

}  // namespace
}  // namespace lookboth
