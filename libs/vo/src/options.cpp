#include "lookboth/vo/options.h"

#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>

#include "lookboth/core/config_layers.h"
#include "lookboth/core/error.h"
#include "lookboth/core/option_fields.h"
#include "lookboth/core/paths.h"
#include "lookboth/core/yaml_reader.h"

namespace lookboth::vo {
namespace {

std::string positive(const char* name, double value) {
  return value > 0 ? "" : std::string("'") + name + "': must be positive";
}

}  // namespace

std::string OdometryOptions::check() const {
  const std::pair<const char*, double> positives[] = {
      {"working_width", double(working_width)},
      {"max_incidence_deg", max_incidence_deg},
      {"max_features", double(max_features)},
      {"grid_cols", double(grid_cols)},
      {"grid_rows", double(grid_rows)},
      {"min_feature_distance_px", min_feature_distance_px},
      {"fast_threshold", fast_threshold},
      {"klt_window_px", double(klt_window_px)},
      {"klt_max_fb_error_px", klt_max_fb_error_px},
      {"ransac_threshold_px", ransac_threshold_px},
      {"ransac_max_iterations", double(ransac_max_iterations)},
      {"init_min_parallax_deg", init_min_parallax_deg},
      {"init_min_inliers", double(init_min_inliers)},
      {"min_tracking_inliers", double(min_tracking_inliers)},
      {"triangulation_min_angle_deg", triangulation_min_angle_deg},
      {"keyframe_translation_ratio", keyframe_translation_ratio},
      {"keyframe_tracked_ratio", keyframe_tracked_ratio},
      {"keyframe_rotation_deg", keyframe_rotation_deg},
      {"max_frames_between_keyframes", double(max_frames_between_keyframes)},
      {"local_window", double(local_window)},
      {"local_iterations", double(local_iterations)},
      {"huber_px", huber_px},
      {"loop_min_keyframe_gap", double(loop_min_keyframe_gap)},
      {"loop_min_inliers", double(loop_min_inliers)},
      {"vocabulary_words", double(vocabulary_words)},
      {"vocabulary_training_keyframes", double(vocabulary_training_keyframes)},
      {"loop_candidates", double(loop_candidates)},
      {"loop_features", double(loop_features)},
      {"global_iterations", double(global_iterations)},
      {"global_sweeps", double(global_sweeps)},
      {"relocalisation_keyframes", double(relocalisation_keyframes)},
      {"max_lost_frames", double(max_lost_frames)},
      {"threads", double(threads)},
  };
  for (const auto& [name, value] : positives) {
    if (std::string why = positive(name, value); !why.empty()) return why;
  }
  if (border_px < 0) return "'border_px': must not be negative";
  if (!(max_rate_hz >= 0 && max_rate_hz <= 1000))
    return "'max_rate_hz': must be between 0 (every frame) and 1000";
  if (klt_levels < 0) return "'klt_levels': must not be negative";
  if (global_max_observations < 0) return "'global_max_observations': must not be negative";
  if (global_min_observations_per_keyframe < 10)
    return "'global_min_observations_per_keyframe': must be at least 10";
  if (max_incidence_deg > 120) return "'max_incidence_deg': must be at most 120";
  if (keyframe_tracked_ratio >= 1) return "'keyframe_tracked_ratio': must be below 1";
  if (min_tracking_inliers < 6) return "'min_tracking_inliers': must be at least 6";
  if (init_min_inliers < 8) return "'init_min_inliers': must be at least 8";
  if (loop_min_inliers < 6) return "'loop_min_inliers': must be at least 6";
  if (local_window < 2) return "'local_window': must be at least 2";
  if (global_window != 0 && global_window < 2 * local_window)
    return "'global_window': must be 0 (one problem) or at least twice 'local_window'";
  return "";
}

// The keys of `odometry:`, in one list that reads and writes them
// (lookboth/core/option_fields.h; found by readOptions and writeOptions
// through argument-dependent lookup).
static void fields(OdometryOptions& o, OptionFields& f) {
  f.integer("working_width", o.working_width);
  f.number("max_rate_hz", o.max_rate_hz);
  f.number("max_incidence_deg", o.max_incidence_deg);
  f.number("border_px", o.border_px);
  f.integer("max_features", o.max_features);
  f.integer("grid_cols", o.grid_cols);
  f.integer("grid_rows", o.grid_rows);
  f.number("min_feature_distance_px", o.min_feature_distance_px);
  f.number("fast_threshold", o.fast_threshold);
  f.integer("klt_window_px", o.klt_window_px);
  f.integer("klt_levels", o.klt_levels);
  f.number("klt_max_fb_error_px", o.klt_max_fb_error_px);
  f.number("ransac_threshold_px", o.ransac_threshold_px);
  f.integer("ransac_max_iterations", o.ransac_max_iterations);
  f.number("init_min_parallax_deg", o.init_min_parallax_deg);
  f.integer("init_min_inliers", o.init_min_inliers);
  f.integer("min_tracking_inliers", o.min_tracking_inliers);
  f.number("triangulation_min_angle_deg", o.triangulation_min_angle_deg);
  f.number("keyframe_translation_ratio", o.keyframe_translation_ratio);
  f.number("keyframe_tracked_ratio", o.keyframe_tracked_ratio);
  f.number("keyframe_rotation_deg", o.keyframe_rotation_deg);
  f.integer("max_frames_between_keyframes", o.max_frames_between_keyframes);
  f.integer("local_window", o.local_window);
  f.integer("local_iterations", o.local_iterations);
  f.number("huber_px", o.huber_px);
  f.flag("loop_closure", o.loop_closure);
  f.integer("loop_min_keyframe_gap", o.loop_min_keyframe_gap);
  f.integer("loop_min_inliers", o.loop_min_inliers);
  f.integer("vocabulary_words", o.vocabulary_words);
  f.integer("vocabulary_training_keyframes", o.vocabulary_training_keyframes);
  f.integer("loop_candidates", o.loop_candidates);
  f.integer("loop_features", o.loop_features);
  f.integer("global_iterations", o.global_iterations);
  f.integer("global_window", o.global_window);
  f.integer("global_sweeps", o.global_sweeps);
  f.integer("global_max_observations", o.global_max_observations);
  f.integer("global_min_observations_per_keyframe", o.global_min_observations_per_keyframe);
  f.integer("relocalisation_keyframes", o.relocalisation_keyframes);
  f.integer("max_lost_frames", o.max_lost_frames);
  f.flag("all_frames", o.all_frames);
  f.integer("threads", o.threads);
  f.unsigned32("seed", o.seed);
}

namespace {

/// One layer's `odometry:` section over `o`, then the check (naming the layer).
void readOdometryLayer(const std::string& text, const std::string& source, OdometryOptions& o) {
  const YamlReader reader(source);
  const YAML::Node root = reader.parse(text);
  reader.checkConfigRoot(root, text);
  if (!root["odometry"]) return;
  const YAML::Node node = root["odometry"];
  if (!node.IsMap()) throw Error(reader.at(node, "odometry"), "expected a mapping");
  readOptions(o, reader, node, "odometry");
  if (const std::string why = o.check(); !why.empty())
    throw Error(source + ": 'odometry." + why.substr(1));
}

}  // namespace

OdometryOptions loadOdometryOptions(const std::filesystem::path& yaml,
                                    const OdometryOptions& defaults) {
  std::ifstream in(yaml);
  if (!in) throw Error(yaml.string() + ": cannot open");
  std::stringstream text;
  text << in.rdbuf();
  OdometryOptions o = defaults;
  readOdometryLayer(text.str(), yaml.string(), o);
  return o;
}

OdometryOptions odometryOptionsFrom(const std::vector<ConfigLayer>& layers) {
  OdometryOptions o;
  for (const ConfigLayer& layer : layers) readOdometryLayer(layer.text, layer.source, o);
  return o;
}

YAML::Node odometryOptionsYaml(const OdometryOptions& options) {
  YAML::Node node;
  writeOptions(options, node);
  return node;
}

OdometryOptions odometryOptionsFor(const std::optional<std::filesystem::path>& user_file) {
  return odometryOptionsFrom(configurationLayers(user_file));
}

}  // namespace lookboth::vo
