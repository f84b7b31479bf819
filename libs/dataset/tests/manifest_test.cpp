#include "lookboth/dataset/manifest.h"

#include <gtest/gtest.h>

#include "lookboth/core/error.h"
#include "test_dataset.h"

namespace lookboth {
namespace {

TEST(Manifest, YamlRoundTripIsExact) {
  const Manifest original = testing::sampleManifest();
  const Manifest back = manifestFromYaml(manifestToYaml(original), "test");
  EXPECT_EQ(back.name, "sample");
  EXPECT_EQ(back.marker.dictionary, "DICT_4X4_50");
  EXPECT_EQ(back.marker.id, 7);
  EXPECT_EQ(back.marker.size_m, 0.2);
  ASSERT_EQ(back.cameras.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back.cameras[i].label, original.cameras[i].label);
    EXPECT_EQ(back.cameras[i].role, original.cameras[i].role);
    ASSERT_TRUE(back.cameras[i].camera);
    EXPECT_EQ(back.cameras[i].camera->params(), original.cameras[i].camera->params());
    EXPECT_EQ(back.cameras[i].camera->modelName(), original.cameras[i].camera->modelName());
  }
  ASSERT_EQ(back.trajectories.size(), 2u);
  EXPECT_FALSE(back.trajectories[0].metric);
  EXPECT_EQ(back.trajectories[0].description, "monocular VO");
  EXPECT_EQ(back.ground_truth.world_from_camera.at("cam01").translation,
            original.ground_truth.world_from_camera.at("cam01").translation);
  EXPECT_EQ(back.ground_truth.world_from_camera.at("cam01").rotation.coeffs(),
            original.ground_truth.world_from_camera.at("cam01").rotation.coeffs());
  EXPECT_EQ(back.ground_truth.fisheye_from_marker->translation,
            original.ground_truth.fisheye_from_marker->translation);
  EXPECT_EQ(back.ground_truth.clock_offset.at("cam01"), -700'000);
  const auto& spans = back.ground_truth.hidden_from_fisheye.at("cam01");
  ASSERT_EQ(spans.size(), 2u);
  EXPECT_EQ(spans[1].begin, 1'500'000'000);
  EXPECT_EQ(spans[1].end, 1'500'000'000);
  EXPECT_EQ(back.fisheye()->label, "fisheye");
}

// A housing is hidden on the spans' stamps, both ends included, and at no
// other time; a camera without spans never is.
TEST(Manifest, HiddenFromFisheyeCoversItsSpansOnly) {
  const GroundTruth truth = testing::sampleManifest().ground_truth;
  EXPECT_FALSE(truth.hiddenFromFisheye("cam01", 999'999'999));
  EXPECT_TRUE(truth.hiddenFromFisheye("cam01", 1'000'000'000));
  EXPECT_TRUE(truth.hiddenFromFisheye("cam01", 1'100'000'000));
  EXPECT_FALSE(truth.hiddenFromFisheye("cam01", 1'100'000'001));
  EXPECT_FALSE(truth.hiddenFromFisheye("cam01", 1'499'999'999));
  EXPECT_TRUE(truth.hiddenFromFisheye("cam01", 1'500'000'000));
  EXPECT_FALSE(truth.hiddenFromFisheye("cam01", 2'000'000'000));
  EXPECT_FALSE(truth.hiddenFromFisheye("cam00", 1'000'000'000));
}

void expectError(const std::string& yaml, const std::vector<std::string>& needles) {
  try {
    manifestFromYaml(yaml, "m.yaml");
    FAIL() << "expected an error for:\n" << yaml;
  } catch (const Error& e) {
    for (const auto& needle : needles)
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(Manifest, ErrorsNameTheField) {
  const std::string head = "lookboth_dataset: 1\n";
  const std::string marker = "marker: {dictionary: DICT_4X4_50, id: 3, size_m: 0.2}\n";
  expectError(head, {"m.yaml", "'marker'", "missing"});
  expectError(head + "marker: {dictionary: DICT_9X9_50, id: 3, size_m: 0.2}\n",
              {"m.yaml:2", "dictionary", "DICT_9X9_50"});
  expectError(head + "marker: {dictionary: DICT_4X4_50, id: 50, size_m: 0.2}\n",
              {"'id'", "ids 0..49"});
  expectError(head + "marker: {dictionary: DICT_4X4_50, id: 3, size_m: -1}\n", {"size_m"});
  expectError("lookboth_dataset: 2\n" + marker, {"version 2"});
  expectError(head + marker + "colour: red\n", {"m.yaml:3", "'colour'", "unknown key"});
  expectError(head + marker +
                  "cameras:\n  - {label: a, role: env_camera}\n  - {label: a, role: env_camera}\n",
              {"label 'a' appears twice"});
  expectError(head + marker + "cameras:\n  - {label: a, role: ceiling}\n",
              {"cameras[0].role", "ceiling"});
  expectError(head + marker +
                  "ground_truth:\n  world_from_camera:\n    camX: {tx: 0, ty: 0, tz: 0, qx: 0, qy: "
                  "0, qz: 0, qw: 1}\n",
              {"ground_truth.world_from_camera.camX", "no environment camera"});
  expectError(head + marker +
                  "ground_truth:\n  fisheye_from_marker: {tx: 0, ty: 0, tz: 0, qx: 0, qy: 0, qz: "
                  "0, qw: 2}\n",
              {"m.yaml:4", "fisheye_from_marker", "norm"});
  expectError(
      head + marker +
          "cameras:\n  - label: c\n    role: env_camera\n    calibration: {lookboth_camera: 1, "
          "model: pinhole, width: 10, height: 10, params: {fx: -1, fy: 1, cx: 5, cy: 5}}\n",
      {"cameras[0].calibration", "fx", "[c]"});
  expectError(head + marker + "trajectories:\n  - {label: vo, metric: maybe}\n",
              {"trajectories[0].metric", "maybe"});
  expectError("lookboth_dataset: [1\n", {"m.yaml", "not valid YAML"});
  const std::string cam = "cameras:\n  - {label: c, role: env_camera}\n";
  expectError(head + marker + cam + "ground_truth:\n  hidden_from_fisheye:\n    d: [[1, 2]]\n",
              {"hidden_from_fisheye.d", "no environment camera"});
  expectError(head + marker + cam + "ground_truth:\n  hidden_from_fisheye:\n    c: [[5, 2]]\n",
              {"hidden_from_fisheye.c", "ends before it begins"});
  expectError(
      head + marker + cam + "ground_truth:\n  hidden_from_fisheye:\n    c: [[1, 4], [3, 6]]\n",
      {"hidden_from_fisheye.c", "overlap"});
  expectError(head + marker + cam + "ground_truth:\n  hidden_from_fisheye:\n    c: [[1, 2, 3]]\n",
              {"m.yaml:7", "[begin_ns, end_ns]"});
}

TEST(Manifest, KnowsTheOpenCvDictionaries) {
  EXPECT_EQ(knownMarkerDictionaries().at("DICT_APRILTAG_36h11"), 587);
  EXPECT_EQ(knownMarkerDictionaries().at("DICT_ARUCO_ORIGINAL"), 1024);
  EXPECT_EQ(MarkerSpec{}.check(), "");
}

}  // namespace
}  // namespace lookboth
