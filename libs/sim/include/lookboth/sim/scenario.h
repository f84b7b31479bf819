// Scenarios of the simulator: a facility, a robot that drives a loop in it,
// environment cameras on its ceiling along the loop, clocks, detection noise
// and faults. Read from YAML (doc/formats.md, "Scenario files"); built-ins in
// share/lookboth/scenarios/<name>.yaml.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "lookboth/dataset/manifest.h"
#include "lookboth/dataset/video_writer.h"
#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/time.h"
#include "lookboth/sim/motion.h"
#include "lookboth/sim/replay.h"
#include "lookboth/sim/world.h"

namespace lookboth::sim {

/// The robot's upward fisheye.
struct FisheyeSpec {
  std::string label = "fisheye";
  std::filesystem::path calibration;  ///< Resolved path of the calibration file.
  double rate_hz = 30;                ///< Frame rate [Hz].
  /// Optical centre in the base frame (x forward, y left, z up from the floor) [m].
  Eigen::Vector3d position_m = Eigen::Vector3d(0.10, 0.0, 0.35);
};

/// The marker's mount: fisheye_from_marker = (translation, Rz(yaw) Ry(pitch) Rx(roll)),
/// in the fisheye frame (x right, y towards the robot's front, z up).
struct MarkerMountSpec {
  Eigen::Vector3d translation_m = Eigen::Vector3d(0.0, -0.15, -0.05);
  double roll_deg = 0, pitch_deg = 0, yaw_deg = 90;
  Rigid3d fisheyeFromMarker() const;
};

/// Wheel odometry: planar dead reckoning from the true motion with a scale
/// error and a yaw-rate bias drawn once per run, plus random walks.
struct OdometrySpec {
  double rate_hz = 50;                         ///< [Hz].
  double scale_error_sigma = 0.005;            ///< Relative error of distances (drawn once).
  double yaw_bias_sigma_deg_per_s = 0.01;      ///< Gyro-like yaw-rate bias (drawn once) [deg/s].
  double distance_noise_m_per_sqrt_m = 0.002;  ///< Random walk of distance [m/sqrt(m)].
  double yaw_noise_deg_per_sqrt_m = 0.05;      ///< Random walk of heading [deg/sqrt(m)].
};

struct RobotSpec {
  MotionSpec motion;  ///< The loop it drives, unless it replays a recorded path:
  ReplaySpec replay;  ///< (replay.h).
  FisheyeSpec fisheye;
  MarkerMountSpec marker_mount;
  OdometrySpec odometry;
  double body_length_m = 0.50, body_width_m = 0.43, body_height_m = 0.25;
};

/// How the environment cameras' rendered frames are stored: one video file
/// per camera (as a recorder keeps them; folder datasets only) instead of a
/// PNG file per frame.
struct CameraVideoSpec {
  std::string codec = "libx264";      ///< An FFmpeg encoder.
  int crf = 23;                       ///< libx264's quality (lower: better, larger).
  std::string preset = "veryfast";    ///< libx264's speed preset.
  double key_frame_interval_s = 1.0;  ///< [s] between key frames (network cameras: 1-2 s).
};

/// The environment cameras, placed along the robot's loop.
struct EnvCamerasSpec {
  int count = 6;
  std::string label_prefix = "cam";   ///< Labels cam00, cam01...
  std::filesystem::path calibration;  ///< Resolved path of the calibration file (all cameras).
  double rate_hz = 30;                ///< [Hz].
  /// Frames exist only while the robot is this close to the nadir [m];
  /// infinity ("all" in a file): every frame of the drive, as a real camera
  /// records it.
  double store_radius_m = 2.5;
  double mount_drop_m = 0.15;  ///< Optical centre below the ceiling's underside [m].
  double tilt_max_deg = 3.0;  ///< Tilt of the optical axis from straight down, uniform in [0, max].
  double lateral_offset_max_m = 0.5;  ///< Offset of the nadir from the path, uniform in +-max [m].
  double min_spacing_m = 0;  ///< Along the path between cameras [m]; 0 = loop length / count.
  double housing_radius_m = 0.06, housing_height_m = 0.10;  ///< The housing the fisheye sees.
  std::optional<CameraVideoSpec> video;                     ///< Absent: a PNG file per frame.
};

/// The encoder's options of `cameras.video` (the defaults when absent): its
/// key frame interval counted in frames at `rate_hz` (with a finite
/// store_radius_m the frames stored are those near the robot, and a key frame
/// comes every so many of them).
VideoEncodeOptions cameraVideoOptions(const EnvCamerasSpec& cameras);

struct ClockSpec {
  TimeNs start_time = secondsToNs(1700000000);      ///< True time of the start (Unix) [ns].
  double offset_min_ms = 1.0, offset_max_ms = 2.0;  ///< |offset| of every node's clock [ms].
  double stamp_resolution_us = 1.0;                 ///< Stamps are rounded to this [us].
};

struct RenderSpec {
  int fisheye_supersampling = 2, env_supersampling = 2;
  double noise_sigma = 2.0;      ///< Pixel noise [grey levels].
  double exposure_jitter = 0.1;  ///< Exposure gain uniform in 1 +- jitter, per frame.
  int png_compression = 3;       ///< 0..9.
};

/// Noise of --detections-only (doc/formats.md: the model).
struct DetectionNoiseSpec {
  double marker_corner_sigma_px = 0.15;  ///< Corner noise that drives the marker pose noise [px].
  double max_view_angle_deg = 60;        ///< Between the marker's normal and the line of sight.
  double min_marker_px = 12;             ///< Shortest side seen [px].
  double image_margin_px = 2;            ///< Corners/blobs must be this far inside [px].
  double blob_sigma_px = 0.7;            ///< Blob centre noise [px].
  /// Marker observations carry the marker's 4 corners (true projections +
  /// N(0, marker_corner_sigma_px^2) per coordinate) and the pose is solved
  /// from them (sim/marker_corners.h); false: the pose noise model alone, no
  /// corners (what every dataset made before this option holds).
  bool marker_corners = false;
  /// The share of a marker detection's error its pass shares (a pass: the
  /// camera's detections with no gap over 1 s): a real detector's error
  /// depends on the viewing geometry, which changes slowly over a pass, so it
  /// does not average out. Each pass's detections move together by a
  /// perturbation of the camera's pose drawn with share times n the pass's
  /// covariance (n its detections): the model `lookboth detect --evaluate`
  /// measures on rendered recordings (its pass_error_share; doc/benchmarks-history.md,
  /// "Marker detection: errors a pass shares") and the joint's
  /// pass_error_share assumes. 0 (the default): independent detections, so
  /// that a scenario and seed give the same dataset with or without the option.
  double marker_pass_share = 0;
};

struct MotionBlurBurst {
  double start_s = 0, end_s = 0;  ///< Since the start of the run [s].
  double blur_px = 0;             ///< RenderOptions::motion_blur_px of the fisheye frames.
};

struct FaultSpec {
  double drop_probability = 0;       ///< Each frame (any camera) lost with this probability.
  std::string clock_jump_node;       ///< "" = none, "random" or a camera label.
  double clock_jump_ms = 0;          ///< Added to that node's clock offset [ms].
  double false_marker_rate = 0;      ///< False detections per stored env-camera frame (<= 1).
  double occlusion_probability = 0;  ///< Marker hidden in a stored env-camera frame.
  bool unvisited_camera = false;     ///< One more camera, away from the loop.
  int duplicated_timestamps = 0;     ///< Records given the previous record's stamp.
  std::vector<MotionBlurBurst> motion_blur;
  std::vector<double> low_texture_region;  ///< (x0, y0, x1, y1) [m]; copied into the world.
  bool any() const;
};

/// A camera moved since the first drive (LaterDriveSpec).
struct CameraMove {
  std::string camera;                                     ///< Its label ("cam03").
  Eigen::Vector3d translate_m = Eigen::Vector3d::Zero();  ///< In the world frame [m].
  Eigen::Vector3d rotate_deg = Eigen::Vector3d::Zero();   ///< Rotation vector, camera frame [deg].
  /// Not empty: the camera was replaced by a new unit with this label (at
  /// the pose moved as above): its own label is gone from the later drive.
  std::string replaced_by;
};

/// The same facility on a later drive (`lookboth check`'s second drive): the
/// world, the cameras' placement and the path come from `seed` as before;
/// every random error (odometry, detections, clocks, faults) from
/// `noise_seed`, and the cameras listed in `moved` have moved.
struct LaterDriveSpec {
  std::uint32_t noise_seed = 0;  ///< 0: the scenario's seed (the first drive).
  std::vector<CameraMove> moved;
  bool active() const { return noise_seed != 0 || !moved.empty(); }
};

/// A marker fixed in the facility (printed on the floor, in the robot
/// marker's dictionary): every camera that sees it detects it, a point whose
/// surveyed position makes a control point of `lookboth align` ("marker:<id>").
/// Rendered frames draw it on top of what is there (the robot passing over
/// it does not hide it).
struct FloorMarkerSpec {
  int id = 0;
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  ///< Its centre, world frame [m].
  double yaw_deg = 0;                                    ///< About the vertical; its face looks up.
  double size_m = 0.3;                                   ///< Side of the black square [m].
};

struct Scenario {
  std::string name;
  std::string description;
  std::uint32_t seed = 1;
  WorldSpec world;
  RobotSpec robot;
  EnvCamerasSpec cameras;
  MarkerSpec marker;
  ClockSpec clocks;
  RenderSpec render;
  DetectionNoiseSpec noise;
  FaultSpec faults;
  LaterDriveSpec later_drive;
  std::vector<FloorMarkerSpec> floor_markers;
  std::filesystem::path source;      ///< The file it was read from ("" when built in code).
  std::map<std::string, int> lines;  ///< Line of each field in `source` (for messages).

  /// Empty when valid; else "'field': message".
  std::string check() const;
  /// The same as (field, message); nullopt when valid.
  std::optional<std::pair<std::string, std::string>> problem() const;
};

/// share/lookboth/scenarios.
std::filesystem::path builtinScenarioDirectory();
/// Names of the built-in scenarios, sorted.
std::vector<std::string> builtinScenarioNames();

/// A built-in name ("small") or a path to a YAML file. Throws lookboth::Error
/// naming the file, line and field; for an unknown name, listing the built-ins.
Scenario loadScenario(const std::string& name_or_file);
/// Parses YAML text; `source` names it in errors; relative calibration paths
/// are looked up in `base_dir`, then in share/lookboth/cameras.
Scenario scenarioFromYaml(const std::string& yaml, const std::string& source,
                          const std::filesystem::path& base_dir);

/// A seed for one random stream ("cameras", "clocks", "frames/cam03"...) of a run.
std::uint32_t streamSeed(std::uint32_t seed, std::string_view stream);
/// A seed for one item (a frame) of a stream.
std::uint32_t itemSeed(std::uint32_t seed, std::string_view stream, std::int64_t index);

/// base_from_fisheye: the fisheye looking up (z up), its image's "down" (y)
/// towards the robot's front.
Rigid3d baseFromFisheye(const FisheyeSpec& fisheye);

/// An environment camera's true pose.
struct EnvCameraPlacement {
  std::string label;
  Rigid3d world_from_camera;
  bool never_visited = false;  ///< The unvisited-camera fault.
};

/// Places the environment cameras along the loop (and the unvisited one, if
/// the fault is on), just under the ceiling given by `ceiling_height_at(x, y)`.
/// Deterministic for a seed. Throws lookboth::Error when the unvisited camera
/// has nowhere to go.
std::vector<EnvCameraPlacement> placeEnvCameras(
    const Scenario& scenario, const RobotPath& motion,
    const std::function<double(double, double)>& ceiling_height_at, std::uint32_t seed);

}  // namespace lookboth::sim
