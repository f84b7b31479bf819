// Options of the fisheye visual odometry (YAML section `odometry:` of a
// lookboth configuration file; defaults in share/lookboth/config/default.yaml,
// fields in doc/formats.md, "Configuration: odometry").
#pragma once
#include <yaml-cpp/yaml.h>
#include "lookboth/core/config_layers.h"

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace lookboth::vo {

struct OdometryOptions {
  // Images.
  int working_width = 640;  ///< Frames wider than this are downscaled by an integer factor [px].
  /// Frames tracked at most this often [Hz]; the others are not decoded
  /// when they are image files (a video's are, in order, but not tracked);
  /// a 30 Hz recording at 15: every other frame. 0 = every frame. On the
  /// `paper` facility's 60 s full recording (30 Hz, 1920x1080), 15 took
  /// `register` from 97 to 73 s but the cameras from 0.87 to 1.43 cm RMS.
  double max_rate_hz = 0;
  double max_incidence_deg =
      90;                ///< Features farther than this from the optical axis are dropped [deg].
  double border_px = 8;  ///< Margin from the image border and the valid circle [px, working].

  // Features and tracking (pixel sizes at the working resolution).
  int max_features = 500;  ///< Tracked features kept per frame.
  int grid_cols = 8;       ///< Detection grid: new features go to cells with few tracks.
  int grid_rows = 6;
  double min_feature_distance_px = 8;  ///< Between tracked features [px].
  double fast_threshold = 6;           ///< FAST corner threshold (intensity levels).
  int klt_window_px = 15;              ///< Lucas-Kanade window side [px].
  int klt_levels = 3;                  ///< Pyramid levels above the working image.
  double klt_max_fb_error_px = 1.0;    ///< Forward-backward consistency bound [px].

  // Geometry.
  double ransac_threshold_px = 2.0;  ///< Inlier bound on the angular error x focal length [px].
  int ransac_max_iterations = 300;
  double init_min_parallax_deg = 2.5;  ///< Median triangulation angle needed to initialise [deg].
  int init_min_inliers = 50;           ///< Inliers of the first two-view geometry.
  int min_tracking_inliers = 15;       ///< Fewer inliers in a frame = tracking lost.
  double triangulation_min_angle_deg = 1.0;  ///< New landmarks need this parallax [deg].

  // Keyframes and local bundle adjustment.
  double keyframe_translation_ratio = 0.06;  ///< New keyframe after moving this x median depth.
  double keyframe_tracked_ratio = 0.65;  ///< ... or when fewer than this share of landmarks remain.
  double keyframe_rotation_deg = 10;     ///< ... or after turning this much [deg].
  int max_frames_between_keyframes = 20;
  int local_window = 12;      ///< Keyframes adjusted at each new keyframe.
  int local_iterations = 10;  ///< Solver iterations of the local adjustment.
  double huber_px = 1.5;      ///< Robust loss scale of the adjustments [px].

  // Loop closure.
  bool loop_closure = true;
  int loop_min_keyframe_gap = 40;          ///< Candidates are at least this many keyframes older.
  int loop_min_inliers = 25;               ///< Verified 2D-3D matches needed to close a loop.
  int vocabulary_words = 512;              ///< Visual words (trained on the first keyframes).
  int vocabulary_training_keyframes = 30;  ///< Keyframes whose descriptors train the vocabulary.
  int loop_candidates = 5;                 ///< Best-scoring keyframes verified per new keyframe.
  int loop_features = 500;                 ///< ORB features per keyframe for place recognition.
  int global_iterations = 30;              ///< Solver iterations of the global adjustment.
  /// Keyframes per problem of the global adjustment: a longer segment is
  /// adjusted in overlapping windows of this many keyframes (after a coarse
  /// pass over at most this many, spread over the segment), so that its
  /// memory does not grow with the length of the run. 0 = one problem over
  /// all keyframes, bounded by global_max_observations (the default: the
  /// windows cost accuracy on some recordings, doc/benchmarks-history.md, "the global adjustment on
  /// an observation budget").
  int global_window = 0;
  int global_sweeps = 2;  ///< Passes over the windows when the segment is longer than one.
  /// Bound on the observations (residual blocks) of the global adjustment's
  /// one problem (global_window 0), i.e. on its memory: a segment whose
  /// landmarks hold more is adjusted, still as one problem over all its
  /// keyframes (Schur complement applied implicitly, not factorised), on a
  /// subset of its landmarks (longest tracks first) that gives each keyframe about
  /// global_max_observations / keyframes observations, and at least
  /// global_min_observations_per_keyframe (beyond global_max_observations /
  /// that many keyframes the problem grows again, by that many observations
  /// per keyframe); the landmarks left out follow their keyframe. 0 = all.
  int global_max_observations = 25000;
  int global_min_observations_per_keyframe = 40;

  // Tracking loss.
  int relocalisation_keyframes = 30;  ///< Recent keyframes matched when relocalising.
  int max_lost_frames = 10;  ///< Then a new segment starts (joined by scale and last pose).

  // Output.
  bool all_frames = true;  ///< Poses of every tracked frame (else keyframes only).

  // Execution.
  int threads = 1;         ///< Solver threads (results do not depend on it for 1).
  std::uint32_t seed = 1;  ///< RANSAC seed.

  /// Empty when valid; else a message naming the field.
  std::string check() const;
};

/// Reads the `odometry:` section of a configuration file over `defaults`
/// (keys absent keep their value; unknown keys are errors naming file and line).
/// A file without the section returns `defaults`.
OdometryOptions loadOdometryOptions(const std::filesystem::path& yaml,
                                    const OdometryOptions& defaults = {});
/// The `odometry:` section that loadOdometryOptions reads back as `options` (every key).
YAML::Node odometryOptionsYaml(const OdometryOptions& options);
/// The options a command uses: share/lookboth/config/default.yaml over the
/// compiled defaults, then the user's file (when given) over it.
/// The `odometry:` sections of the configuration's layers
/// (core/config_layers.h), each over the ones before, over the compiled defaults.
OdometryOptions odometryOptionsFrom(const std::vector<ConfigLayer>& layers);
OdometryOptions odometryOptionsFor(const std::optional<std::filesystem::path>& user_file);

}  // namespace lookboth::vo
