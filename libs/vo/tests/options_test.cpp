#include "lookboth/vo/options.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "lookboth/core/error.h"
#include "lookboth/core/option_fields.h"
#include "lookboth/core/scoped_environment.h"

namespace lookboth::vo {
namespace {

std::filesystem::path writeTemp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / name;
  std::ofstream(path) << text;
  return path;
}

TEST(OdometryOptionsTest, DefaultsAreValid) { EXPECT_EQ(OdometryOptions().check(), ""); }

TEST(OdometryOptionsTest, CheckNamesTheField) {
  OdometryOptions o;
  o.max_features = 0;
  EXPECT_NE(o.check().find("'max_features'"), std::string::npos);
  OdometryOptions budget;
  budget.global_max_observations = -1;
  EXPECT_NE(budget.check().find("'global_max_observations'"), std::string::npos);
  budget.global_max_observations = 0;  // no bound
  EXPECT_EQ(budget.check(), "");
  budget.global_min_observations_per_keyframe = 5;
  EXPECT_NE(budget.check().find("'global_min_observations_per_keyframe'"), std::string::npos);
}

// default.yaml says what the compiled defaults say, every key (a library
// user or a test that builds OdometryOptions in code runs what
// `lookboth odometry` runs).
TEST(OdometryOptionsTest, ShippedDefaultConfigReadsAsTheDefaults) {
  const OdometryOptions loaded =
      loadOdometryOptions(std::filesystem::path(LOOKBOTH_SHARE_DIR) / "config" / "default.yaml");
  const std::vector<std::string> found = optionDifferences(
      odometryOptionsYaml(loaded), odometryOptionsYaml(OdometryOptions()), "odometry");
  std::string listed;
  for (const std::string& line : found) listed += "\n  " + line;
  EXPECT_TRUE(found.empty()) << "default.yaml's value against the compiled one:" << listed;
  EXPECT_EQ(odometryOptionsYaml(OdometryOptions()).size(), 42u);  // every key written
}

// Settings held in memory, the last layer, reach the odometry too.
TEST(OdometryOptionsTest, InMemorySettingsAreTheLastLayer) {
  const OdometryOptions o =
      odometryOptionsFrom(configurationLayers(std::nullopt, "odometry: {max_features: 321}\n"));
  EXPECT_EQ(o.max_features, 321);
  EXPECT_EQ(o.seed, OdometryOptions().seed);
  EXPECT_THROW(odometryOptionsFrom(configurationLayers(std::nullopt, "odometry: {seed: -1}\n")),
               Error);
}

// The user's --config layers over default.yaml (a share folder whose
// default.yaml differs from the compiled defaults).
TEST(OdometryOptionsTest, TheUsersFileLayersOverDefaultYaml) {
  const auto share = std::filesystem::temp_directory_path() / "lookboth_vo_layer_test";
  std::filesystem::create_directories(share / "config");
  std::filesystem::create_directories(share / "cameras");  // what marks a share folder
  std::ofstream(share / "config" / "default.yaml") << "odometry: {max_features: 333, seed: 5}\n";
  const auto user = writeTemp("lookboth_vo_layer_user.yaml", "odometry: {seed: 9}\n");
  OdometryOptions plain, layered;
  {
    const ScopedEnvironment share_dir("LOOKBOTH_SHARE_DIR", share.string());
    plain = odometryOptionsFor(std::nullopt);
    layered = odometryOptionsFor(user);
  }
  std::filesystem::remove_all(share);
  std::filesystem::remove(user);
  EXPECT_EQ(plain.max_features, 333);
  EXPECT_EQ(plain.seed, 5u);
  EXPECT_EQ(layered.max_features, 333);  // from default.yaml
  EXPECT_EQ(layered.seed, 9u);           // the user's
}

TEST(OdometryOptionsTest, ReadsValuesAndRejectsUnknownKeys) {
  const auto good =
      writeTemp("vo_options_good.yaml", "odometry:\n  max_features: 123\n  loop_closure: false\n");
  const OdometryOptions o = loadOdometryOptions(good);
  EXPECT_EQ(o.max_features, 123);
  EXPECT_FALSE(o.loop_closure);
  const auto bad = writeTemp("vo_options_bad.yaml", "odometry:\n  max_featurez: 123\n");
  try {
    loadOdometryOptions(bad);
    FAIL() << "unknown key accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("max_featurez"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("vo_options_bad.yaml:2"), std::string::npos) << e.what();
  }
  const auto invalid = writeTemp("vo_options_invalid.yaml", "odometry:\n  local_window: 1\n");
  EXPECT_THROW(loadOdometryOptions(invalid), Error);
}

}  // namespace
}  // namespace lookboth::vo
