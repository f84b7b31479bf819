// The stages' options: share/lookboth/config/default.yaml says what the
// compiled defaults say (a library user, a test or a benchmark that builds
// the options in code runs what `lookboth register` runs), and write() then
// read() gives the same options back.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "lookboth/calib/builtin_stages.h"
#include "lookboth/core/error.h"
#include "lookboth/core/option_fields.h"

namespace lookboth {
namespace {

YAML::Node registerSection(const YamlReader& reader) {
  const std::filesystem::path file =
      std::filesystem::path(LOOKBOTH_SHARE_DIR) / "config" / "default.yaml";
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return reader.parse(text.str())["register"];
}

/// For one stage: default.yaml's section read over the compiled defaults
/// against the compiled defaults alone ("default.yaml's value against the
/// compiled one" per key that differs).
template <typename Options>
std::vector<std::string> defaultYamlAgainstCompiled(const std::string& stage) {
  const YamlReader reader("default.yaml");
  const YAML::Node section = registerSection(reader)[stage];
  EXPECT_TRUE(section.IsMap()) << "default.yaml has no register." << stage << " section";
  Options loaded;
  loaded.read(reader, section, "register." + stage);
  YAML::Node from_file, compiled;
  loaded.write(from_file);
  Options().write(compiled);
  EXPECT_GT(compiled.size(), 1u) << stage << ": write() wrote nothing";
  return optionDifferences(from_file, compiled, "register." + stage);
}

TEST(StageOptions, DefaultYamlSaysWhatTheCompiledDefaultsSay) {
  std::vector<std::string> all;
  for (const auto& found :
       {defaultYamlAgainstCompiled<AssociateOptions>("associate"),
        defaultYamlAgainstCompiled<MotionCalibrationOptions>("motion_calibration"),
        defaultYamlAgainstCompiled<LookDownOptions>("look_down"),
        defaultYamlAgainstCompiled<LookUpOptions>("look_up"),
        defaultYamlAgainstCompiled<JointOptions>("joint")}) {
    all.insert(all.end(), found.begin(), found.end());
  }
  // default.yaml's one choice that is not a library default: the simulator
  // robot's measured mount as the prior for what a flat floor cannot
  // determine (default.yaml tells the user to measure theirs); a library
  // user states their own robot's.
  const std::string robot_specific = "register.motion_calibration.prior_translation_m: ";
  std::string listed;
  int robot = 0;
  for (const std::string& line : all) {
    if (line.rfind(robot_specific, 0) == 0) {
      ++robot;
    } else {
      listed += "\n  " + line;
    }
  }
  EXPECT_TRUE(listed.empty()) << "default.yaml's value against the compiled one:" << listed;
  EXPECT_EQ(robot, 1) << "default.yaml sets the simulated robot's mount as the prior";
}

/// Writes `options`, reads the text back over the compiled defaults, and
/// returns what differs.
template <typename Options>
std::vector<std::string> roundTrip(const Options& options) {
  YAML::Node written;
  options.write(written);
  const YamlReader reader("written");
  Options read_back;
  read_back.read(reader, reader.parse(YAML::Dump(written)), "register.stage");
  YAML::Node again;
  read_back.write(again);
  return optionDifferences(written, again, "register.stage");
}

TEST(StageOptions, WhatWriteWritesReadReadsBack) {
  MotionCalibrationOptions motion;
  motion.sigma_rotation_deg = 0.7;
  motion.prior_translation_m = Eigen::Vector3d(0.1, -0.2, 0.3);
  motion.prior_rotation = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()));
  motion.translation_from_camera_orientation = !motion.translation_from_camera_orientation;
  EXPECT_EQ(roundTrip(motion), std::vector<std::string>());
  EXPECT_EQ(roundTrip(MotionCalibrationOptions()), std::vector<std::string>());

  AssociateOptions associate;
  associate.max_gap_s = 0.25;
  associate.clock_offsets_ns = {{"cam03", -150000000}, {"cam07", 42}};
  EXPECT_EQ(roundTrip(associate), std::vector<std::string>());

  JointOptions joint;
  joint.blob_offset_in_camera_m = Eigen::Vector3d(0.01, 0.02, -0.03);
  joint.fill_reducing_ordering = "amd";
  joint.use_corners = !joint.use_corners;
  joint.rounds = 7;
  EXPECT_EQ(roundTrip(joint), std::vector<std::string>());

  // A value write() left out would come back as the compiled default.
  YAML::Node written;
  joint.write(written);
  EXPECT_EQ(written["rounds"].as<int>(), 7);
  EXPECT_EQ(written["fill_reducing_ordering"].as<std::string>(), "amd");
}

TEST(StageOptions, AChangedDefaultIsNamedWithBothValues) {
  // The comparison the first test makes, on a section that differs.
  const YamlReader reader("user.yaml");
  LookDownOptions loaded;
  loaded.read(reader, reader.parse("{huber: 0.123, min_detections: 9}"), "register.look_down");
  YAML::Node from_file, compiled;
  loaded.write(from_file);
  LookDownOptions().write(compiled);
  const std::vector<std::string> found =
      optionDifferences(from_file, compiled, "register.look_down");
  ASSERT_EQ(found.size(), 2u);
  EXPECT_NE(found[0].find("register.look_down.min_detections: 9 against"), std::string::npos)
      << found[0];
  EXPECT_NE(found[1].find("register.look_down.huber: 0.123 against"), std::string::npos)
      << found[1];
}

TEST(StageOptions, ClockOffsetsMustBeAMapping) {
  const YamlReader reader("user.yaml");
  AssociateOptions options;
  try {
    options.read(reader, reader.parse("{clock_offsets_ns: [1, 2]}"), "register.associate");
    ADD_FAILURE() << "a list of clock offsets was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("register.associate.clock_offsets_ns"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("expected a mapping label: ns"), std::string::npos)
        << e.what();
  }
}

TEST(StageOptions, UnknownKeysAreStillErrors) {
  const YamlReader reader("user.yaml");
  JointOptions joint;
  EXPECT_THROW(joint.read(reader, reader.parse("{roundz: 3}"), "register.joint"), Error);
  LookUpOptions look_up;
  EXPECT_THROW(
      look_up.read(reader, reader.parse("{blob_offset_in_camera_m: [1, 2]}"), "register.look_up"),
      Error);
}

}  // namespace
}  // namespace lookboth
