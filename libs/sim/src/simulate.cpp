#include "lookboth/sim/simulate.h"

#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <mutex>
#include <opencv2/aruco.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <thread>

#include "lookboth/cameras/camera_io.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/dataset/video_writer.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/time.h"
#include "lookboth/sim/marker_corners.h"
#include "lookboth/sim/motion.h"
#include "lookboth/sim/render.h"
#include "lookboth/sim/replay.h"
#include "lookboth/sim/scenario.h"
#include "lookboth/sim/world.h"

namespace lookboth::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

enum class EventKind : int { kGroundTruth = 0, kOdometry = 1, kFisheye = 2, kEnv = 3 };

/// One thing that happens at one instant: a frame, a trajectory sample.
struct Event {
  TimeNs stamp = 0;  ///< In the clock of the node that stamps it.
  double t = 0;      ///< True time since the start [s].
  EventKind kind = EventKind::kGroundTruth;
  int camera = -1;            ///< Env camera index (kEnv).
  std::int64_t index = 0;     ///< Frame or sample index in its stream.
  Rigid3d pose;               ///< Trajectory samples: world_from_fisheye.
  double exposure = 1.0;      ///< Frames.
  double blur_px = 0;         ///< Fisheye frames.
  bool occluded = false;      ///< Env frames: the marker is hidden.
  bool false_marker = false;  ///< Env frames: a false detection (decoy) in this frame.
  bool duplicated = false;    ///< Carries the previous record's stamp (a fault).
  /// Detections-only env frames: the marker observation to write, if any.
  std::optional<MarkerObservation> marker;
  /// Detections-only env frames: the floor markers (scenario floor_markers) seen.
  std::vector<MarkerObservation> floor_markers;
};

double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}
double gaussian(std::mt19937& rng) { return std::normal_distribution<double>(0.0, 1.0)(rng); }

TimeNs roundTo(TimeNs value, TimeNs step) {
  if (step <= 1) return value;
  const TimeNs half = step / 2;
  return (value >= 0 ? (value + half) / step : -((-value + half) / step)) * step;
}

double yawOf(const Rigid3d& pose) {
  const Eigen::Vector3d x = pose.rotation * Eigen::Vector3d::UnitX();
  return std::atan2(x.y(), x.x());
}

double wrapAngle(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a <= -kPi) a += 2 * kPi;
  return a;
}

std::uintmax_t sizeOf(const fs::path& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) return fs::file_size(path, ec);
  std::uintmax_t total = 0;
  if (fs::is_directory(path, ec)) {
    for (const auto& entry : fs::recursive_directory_iterator(path, ec)) {
      if (entry.is_regular_file(ec)) total += entry.file_size(ec);
    }
  }
  return total;
}

/// Everything the run needs, built once.
struct Setup {
  Scenario scenario;
  std::uint32_t seed = 0;        ///< The world, the cameras' placement, the path.
  std::uint32_t noise_seed = 0;  ///< Every random error (later_drive.noise_seed, else seed).
  std::optional<Camera> fisheye, env_camera;
  std::unique_ptr<World> world;
  std::unique_ptr<RobotPath> motion;
  std::vector<ReplayedPose> replayed_odometry;  ///< robot.replay.odometry, when given.
  std::vector<EnvCameraPlacement> placements;
  Rigid3d base_from_fisheye, fisheye_from_marker;
  TimeNs robot_offset = 0;             ///< Robot clock - true time [ns].
  std::vector<TimeNs> camera_offsets;  ///< Camera clock - true time [ns].
  std::vector<double> camera_phase;    ///< First frame's true time [s].
  std::vector<double> camera_gain;     ///< Exposure gain per camera.
  double fisheye_phase = 0, odometry_phase = 0;
  double duration = 0;  ///< Simulated time [s].
  std::vector<std::string> fault_notes;
  /// Each environment camera's static view, for full recordings (empty otherwise).
  std::vector<EnvBackground> backgrounds;

  TimeNs stamp(double t, TimeNs offset) const {
    const TimeNs step =
        static_cast<TimeNs>(std::llround(scenario.clocks.stamp_resolution_us * 1000));
    return roundTo(scenario.clocks.start_time + static_cast<TimeNs>(std::llround(t * 1e9)) + offset,
                   step);
  }
  Rigid3d worldFromFisheye(double t) const { return motion->worldFromBase(t) * base_from_fisheye; }
  Rigid3d worldFromMarker(double t) const { return worldFromFisheye(t) * fisheye_from_marker; }
};

// ---------------------------------------------------------------------------
// Marker detection model (detections-only)

/// The marker's corners in its own frame, in ArUco's order (top-left,
/// top-right, bottom-right, bottom-left; x right, y up).
std::array<Eigen::Vector3d, 4> markerCorners(double size) {
  const double h = 0.5 * size;
  return {Eigen::Vector3d(-h, h, 0), Eigen::Vector3d(h, h, 0), Eigen::Vector3d(h, -h, 0),
          Eigen::Vector3d(-h, -h, 0)};
}

/// Mean side of the marker in pixels when it is detectable from the camera
/// (all corners in the image, facing the camera, large enough); nullopt otherwise.
std::optional<double> detectableSide(const Camera& camera, const Rigid3d& camera_from_marker,
                                     const MarkerSpec& marker, const DetectionNoiseSpec& noise) {
  const Eigen::Vector3d to_camera = -camera_from_marker.translation.normalized();
  const Eigen::Vector3d normal = camera_from_marker.rotation * Eigen::Vector3d::UnitZ();
  if (normal.dot(to_camera) < std::cos(noise.max_view_angle_deg * kDegree)) return std::nullopt;
  std::array<Eigen::Vector2d, 4> pixels;
  const auto corners = markerCorners(marker.size_m);
  for (int i = 0; i < 4; ++i) {
    const auto pixel = camera.project(camera_from_marker * corners[static_cast<size_t>(i)]);
    if (!pixel || !camera.isInImage(*pixel, noise.image_margin_px)) return std::nullopt;
    pixels[static_cast<size_t>(i)] = *pixel;
  }
  double sum = 0, shortest = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i) {
    const double side =
        (pixels[static_cast<size_t>((i + 1) % 4)] - pixels[static_cast<size_t>(i)]).norm();
    sum += side;
    shortest = std::min(shortest, side);
  }
  if (shortest < noise.min_marker_px) return std::nullopt;
  return sum / 4;
}

/// A noisy marker pose and its information, by the model of doc/formats.md.
MarkerObservation noisyMarker(const Rigid3d& camera_from_marker, double side_px,
                              const MarkerSpec& marker, const DetectionNoiseSpec& noise,
                              std::mt19937& rng) {
  const double sigma_c = std::max(noise.marker_corner_sigma_px, 1e-6);
  const double d = camera_from_marker.translation.norm();
  const double size = marker.size_m;
  const double sigma_lateral = 0.5 * sigma_c * size / side_px;
  const double sigma_depth = d * sigma_c / (std::sqrt(2.0) * side_px);
  const double sigma_in_plane = sigma_c / (std::sqrt(2.0) * side_px);
  const double sigma_tilt = std::min(0.5, std::sqrt(2.0) * sigma_c * d / (side_px * size));
  const Eigen::Vector3d u = camera_from_marker.translation / d;
  Eigen::Vector3d e1 = u.cross(Eigen::Vector3d::UnitX());
  if (e1.norm() < 0.1) e1 = u.cross(Eigen::Vector3d::UnitY());
  e1.normalize();
  const Eigen::Vector3d e2 = u.cross(e1);
  const double n[6] = {gaussian(rng), gaussian(rng), gaussian(rng),
                       gaussian(rng), gaussian(rng), gaussian(rng)};
  const Eigen::Vector3d dt = sigma_lateral * (n[0] * e1 + n[1] * e2) + sigma_depth * n[2] * u;
  const Eigen::Vector3d dtheta(sigma_tilt * n[3], sigma_tilt * n[4], sigma_in_plane * n[5]);
  MarkerObservation obs;
  obs.marker_id = marker.id;
  obs.camera_from_marker.translation = camera_from_marker.translation - dt;
  obs.camera_from_marker.rotation =
      (camera_from_marker.rotation * so3Exp(Eigen::Vector3d(-dtheta))).normalized();
  const Eigen::Matrix3d uu = u * u.transpose();
  obs.information.setZero();
  obs.information.topLeftCorner<3, 3>() =
      (Eigen::Matrix3d::Identity() - uu) / (sigma_lateral * sigma_lateral) +
      uu / (sigma_depth * sigma_depth);
  obs.information.bottomRightCorner<3, 3>() =
      Eigen::Vector3d(1 / (sigma_tilt * sigma_tilt), 1 / (sigma_tilt * sigma_tilt),
                      1 / (sigma_in_plane * sigma_in_plane))
          .asDiagonal();
  return obs;
}

/// A decoy: a copy of the marker lying on the floor somewhere in the
/// camera's view (a printed copy, a reflection...). nullopt when the drawn
/// place is not detectable.
std::optional<Rigid3d> decoyWorldFromMarker(const Camera& camera, const Rigid3d& world_from_camera,
                                            std::mt19937& rng) {
  // v first: one order of the draws on every compiler (lookboth/geometry/random.h).
  const double v = uniform(rng, 0.15, 0.85) * camera.height();
  const Eigen::Vector2d pixel(uniform(rng, 0.15, 0.85) * camera.width(), v);
  const double yaw = uniform(rng, 0, 2 * kPi);
  const auto ray = camera.unproject(pixel);
  if (!ray) return std::nullopt;
  const Eigen::Vector3d direction = world_from_camera.rotation * *ray;
  if (direction.z() > -0.2) return std::nullopt;
  const double s = -world_from_camera.translation.z() / direction.z();
  Eigen::Vector3d point = world_from_camera.translation + s * direction;
  point.z() = 0.001;
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())), point);
}

/// noise.marker_pass_share: a camera's marker detections (its events from
/// `first`; decoys left alone) get the bias of their pass (no gap over 1 s),
/// drawn by addPassBias from the stream pass/<camera>, one draw per pass.
void sharePassErrors(std::vector<Event>& events, std::size_t first, const Camera& camera,
                     const Scenario& sc, std::uint32_t seed, const std::string& label) {
  std::vector<Event*> seen;
  for (std::size_t i = first; i < events.size(); ++i) {
    if (events[i].marker && !events[i].false_marker) seen.push_back(&events[i]);
  }
  std::vector<TimeNs> times;
  for (const Event* e : seen) times.push_back(secondsToNsRounded(e->t));
  std::int64_t pass = 0;
  for (const auto& [begin, end] : runsWithinGap(times, kNanosecondsPerSecond)) {
    std::vector<MarkerObservation*> members;
    for (std::size_t i = begin; i < end; ++i) members.push_back(&*seen[i]->marker);
    std::mt19937 rng(itemSeed(seed, "pass/" + label, pass++));
    addPassBias(members, sc.noise.marker_pass_share, rng, &camera, sc.marker.size_m);
  }
}

// ---------------------------------------------------------------------------
// Building the run

/// The cameras a later drive finds moved or replaced (LaterDriveSpec).
void moveCameras(const LaterDriveSpec& later, std::vector<EnvCameraPlacement>& placements) {
  auto find = [&](const std::string& label) {
    return std::find_if(placements.begin(), placements.end(),
                        [&](const EnvCameraPlacement& p) { return p.label == label; });
  };
  for (const CameraMove& move : later.moved) {
    const auto it = find(move.camera);
    if (it == placements.end()) {
      throw Error("later_drive.moved: no camera '" + move.camera + "' in the scenario");
    }
    if (!move.replaced_by.empty()) {
      if (find(move.replaced_by) != placements.end()) {
        throw Error("later_drive.moved: '" + move.replaced_by +
                    "' cannot label the new unit: a camera of the scenario has it");
      }
      it->label = move.replaced_by;
    }
    const Eigen::Vector3d rotation = move.rotate_deg * (M_PI / 180);
    it->world_from_camera =
        Rigid3d((it->world_from_camera.rotation *
                 Eigen::Quaterniond(Eigen::AngleAxisd(
                     rotation.norm(),
                     rotation.norm() > 0 ? rotation.normalized() : Eigen::Vector3d::UnitX())))
                    .normalized(),
                it->world_from_camera.translation + move.translate_m);
  }
}

Setup buildSetup(const SimulateOptions& options) {
  Setup setup;
  setup.scenario = loadScenario(options.scenario);
  const Scenario& sc = setup.scenario;
  setup.seed = options.seed.value_or(sc.seed);
  const std::uint32_t seed = setup.seed;
  setup.noise_seed = sc.later_drive.noise_seed != 0 ? sc.later_drive.noise_seed : seed;
  setup.fisheye = loadCamera(sc.robot.fisheye.calibration);
  setup.env_camera = loadCamera(sc.cameras.calibration);
  WorldSpec world_spec = sc.world;
  world_spec.low_texture_region = sc.faults.low_texture_region;
  setup.world = std::make_unique<World>(world_spec, streamSeed(seed, "world"));
  if (sc.robot.replay.active()) {
    auto replay =
        std::make_unique<ReplayedMotion>(sc.robot.replay, sc.world.length_m, sc.world.width_m);
    if (!sc.robot.replay.odometry.empty()) setup.replayed_odometry = replayedOdometry(*replay);
    setup.motion = std::move(replay);
  } else {
    setup.motion = std::make_unique<RobotMotion>(sc.robot.motion, streamSeed(seed, "floor"));
  }
  const World& world = *setup.world;
  setup.placements = placeEnvCameras(
      sc, *setup.motion, [&world](double x, double y) { return world.ceilingHeightAt(x, y); },
      seed);
  moveCameras(sc.later_drive, setup.placements);
  for (const EnvCameraPlacement& p : setup.placements) {
    Housing housing;
    housing.label = p.label;
    housing.centre_in_world = p.world_from_camera.translation;
    housing.radius_m = sc.cameras.housing_radius_m;
    housing.height_m = sc.cameras.housing_height_m;
    setup.world->addHousing(housing);
  }
  setup.base_from_fisheye = baseFromFisheye(sc.robot.fisheye);
  setup.fisheye_from_marker = sc.robot.marker_mount.fisheyeFromMarker();

  // Clocks: every node off by 1-2 ms (either sign); sensors not triggered together.
  std::mt19937 clocks(streamSeed(setup.noise_seed, "clocks"));
  auto offset = [&]() {
    const double sign = uniform(clocks, 0, 1) < 0.5 ? -1.0 : 1.0;
    const double ms = uniform(clocks, sc.clocks.offset_min_ms, sc.clocks.offset_max_ms);
    return static_cast<TimeNs>(std::llround(sign * ms * 1e6));
  };
  setup.robot_offset = offset();
  setup.fisheye_phase = uniform(clocks, 0, 1 / sc.robot.fisheye.rate_hz);
  setup.odometry_phase = uniform(clocks, 0, 1 / sc.robot.odometry.rate_hz);
  for (size_t i = 0; i < setup.placements.size(); ++i) {
    setup.camera_offsets.push_back(offset());
    setup.camera_phase.push_back(uniform(clocks, 0, 1 / sc.cameras.rate_hz));
    setup.camera_gain.push_back(1 + 0.5 * sc.render.exposure_jitter * uniform(clocks, -1, 1));
  }

  // Faults decided once.
  std::mt19937 faults(streamSeed(setup.noise_seed, "faults"));
  if (!sc.faults.clock_jump_node.empty()) {
    const TimeNs jump = static_cast<TimeNs>(std::llround(sc.faults.clock_jump_ms * 1e6));
    std::string node = sc.faults.clock_jump_node;
    if (node == "random") {
      std::vector<size_t> visited;
      for (size_t i = 0; i < setup.placements.size(); ++i)
        if (!setup.placements[i].never_visited) visited.push_back(i);
      node = setup
                 .placements[visited[static_cast<size_t>(uniform(faults, 0, 1) *
                                                         static_cast<double>(visited.size())) %
                                     visited.size()]]
                 .label;
    }
    bool found = false;
    if (node == sc.robot.fisheye.label || node == "robot") {
      setup.robot_offset += jump;
      found = true;
    }
    for (size_t i = 0; i < setup.placements.size() && !found; ++i) {
      if (setup.placements[i].label == node) {
        setup.camera_offsets[i] += jump;
        found = true;
      }
    }
    if (!found) {
      std::string labels = sc.robot.fisheye.label;
      for (const auto& p : setup.placements) labels += ", " + p.label;
      const auto line = sc.lines.find("faults.clock_jump.node");
      throw Error(ErrorContext{sc.source.string(), line == sc.lines.end() ? 0 : line->second,
                               "faults.clock_jump.node", ""},
                  "no node '" + node + "' (random, robot or one of: " + labels + ")");
    }
    setup.fault_notes.push_back("clock of " + node + " off by " +
                                formatFixed(sc.faults.clock_jump_ms, 1) + " ms more");
  }
  for (const auto& p : setup.placements) {
    if (p.never_visited) setup.fault_notes.push_back(p.label + " is never passed under");
  }
  if (!sc.faults.low_texture_region.empty()) {
    const auto& r = sc.faults.low_texture_region;
    setup.fault_notes.push_back("plain ceiling over x " + formatDouble(r[0]) + ".." +
                                formatDouble(r[2]) + " m, y " + formatDouble(r[1]) + ".." +
                                formatDouble(r[3]) + " m");
  }
  setup.duration = setup.motion->duration();
  if (options.max_duration_s > 0) setup.duration = std::min(setup.duration, options.max_duration_s);
  return setup;
}

/// Each housing's spans of fisheye frames in which the world hides its
/// centre from the fisheye, on the fisheye's stamps. Only housings inside the
/// frame are cast (a ray each); one outside it is in no span.
std::map<std::string, std::vector<TimeSpan>> hiddenFromFisheye(const Setup& setup) {
  const World& world = *setup.world;
  const double period = 1 / setup.scenario.robot.fisheye.rate_hz;
  std::map<std::string, std::vector<TimeSpan>> hidden;
  std::vector<bool> was_hidden(world.housings().size(), false);
  for (std::int64_t k = 0;; ++k) {
    const double t = setup.fisheye_phase + static_cast<double>(k) * period;
    if (t > setup.duration) break;
    const TimeNs stamp = setup.stamp(t, setup.robot_offset);
    const Rigid3d world_from_fisheye = setup.worldFromFisheye(t);
    for (size_t i = 0; i < world.housings().size(); ++i) {
      const Housing& housing = world.housings()[i];
      const Eigen::Vector3d towards = housing.centre_in_world - world_from_fisheye.translation;
      const auto pixel = setup.fisheye->project(world_from_fisheye.rotation.inverse() * towards);
      const bool in_frame = pixel && setup.fisheye->isInImage(*pixel, 0.0);
      const bool now =
          in_frame &&
          world.intersect(world_from_fisheye.translation, towards.normalized()).housing !=
              static_cast<int>(i);
      if (now && was_hidden[i]) hidden[housing.label].back().end = stamp;
      if (now && !was_hidden[i]) hidden[housing.label].push_back({stamp, stamp});
      was_hidden[i] = now;
    }
  }
  return hidden;
}

Manifest buildManifest(const Setup& setup, const SimulateOptions& options) {
  const Scenario& sc = setup.scenario;
  Manifest manifest;
  manifest.name = options.kind == DatasetKind::kRawlog ? options.out.stem().string()
                                                       : options.out.filename().string();
  manifest.marker = sc.marker;
  manifest.cameras.push_back({sc.robot.fisheye.label, SensorRole::kFisheye, setup.fisheye});
  for (const EnvCameraPlacement& p : setup.placements)
    manifest.cameras.push_back({p.label, SensorRole::kEnvCamera, setup.env_camera});
  const OdometrySpec& o = sc.robot.odometry;
  const ReplaySpec& replay = sc.robot.replay;
  if (!setup.replayed_odometry.empty()) {
    manifest.trajectories.push_back(
        {"odometry", replay.metric,
         "the estimate " + replay.odometry.filename().string() + " replayed: its error against " +
             replay.path.filename().string() + " carried onto the fisheye's path" +
             (replay.metric ? "" : " (its scale unknown, as the estimate's)")});
  } else {
    manifest.trajectories.push_back(
        {"odometry", true,
         "simulated wheel odometry of the fisheye (" + formatDouble(o.rate_hz) +
             " Hz; distance scale error sigma " + formatDouble(o.scale_error_sigma) +
             ", yaw-rate bias sigma " + formatDouble(o.yaw_bias_sigma_deg_per_s) + " deg/s)"});
  }
  manifest.trajectories.push_back(
      {"ground_truth", true, "simulator ground truth: world_from_fisheye at the fisheye's frames"});
  manifest.ground_truth.fisheye_from_marker = setup.fisheye_from_marker;
  manifest.ground_truth.clock_offset[sc.robot.fisheye.label] = 0;
  for (size_t i = 0; i < setup.placements.size(); ++i) {
    const EnvCameraPlacement& p = setup.placements[i];
    manifest.ground_truth.world_from_camera[p.label] = p.world_from_camera;
    manifest.ground_truth.clock_offset[p.label] = setup.camera_offsets[i] - setup.robot_offset;
  }
  manifest.ground_truth.hidden_from_fisheye = hiddenFromFisheye(setup);
  return manifest;
}

double blurAt(const Scenario& sc, double t) {
  double blur = 0;
  for (const MotionBlurBurst& b : sc.faults.motion_blur) {
    if (t >= b.start_s && t <= b.end_s) blur = std::max(blur, b.blur_px);
  }
  return blur;
}

/// The fisheye's frames and the ground truth at each.
void addFisheyeEvents(const Setup& setup, std::vector<Event>& events,
                      std::map<std::string, std::int64_t>& fault_counts) {
  const Scenario& sc = setup.scenario;
  const std::uint32_t seed = setup.noise_seed;
  const double duration = setup.duration;
  const double fisheye_period = 1 / sc.robot.fisheye.rate_hz;
  for (std::int64_t k = 0;; ++k) {
    const double t = setup.fisheye_phase + static_cast<double>(k) * fisheye_period;
    if (t > duration) break;
    Event gt;
    gt.kind = EventKind::kGroundTruth;
    gt.t = t;
    gt.index = k;
    gt.stamp = setup.stamp(t, setup.robot_offset);
    gt.pose = setup.worldFromFisheye(t);
    events.push_back(gt);
    std::mt19937 rng(itemSeed(seed, "faults/" + sc.robot.fisheye.label, k));
    const bool dropped = uniform(rng, 0, 1) < sc.faults.drop_probability;
    Event frame = gt;
    frame.kind = EventKind::kFisheye;
    frame.exposure = 1 + sc.render.exposure_jitter * uniform(rng, -1, 1);
    frame.blur_px = blurAt(sc, t);
    if (frame.blur_px > 0) ++fault_counts["motion-blurred fisheye frames"];
    if (dropped) {
      ++fault_counts["dropped frames"];
      continue;
    }
    events.push_back(frame);
  }
}

/// A replayed estimate, where it lies within the simulated time.
void addReplayedOdometry(const Setup& setup, std::vector<Event>& events) {
  const double duration = setup.duration;
  for (size_t j = 0; j < setup.replayed_odometry.size(); ++j) {
    const ReplayedPose& pose = setup.replayed_odometry[j];
    if (pose.t > duration) break;
    Event e;
    e.kind = EventKind::kOdometry;
    e.t = pose.t;
    e.index = static_cast<std::int64_t>(j);
    e.stamp = setup.stamp(pose.t, setup.robot_offset);
    e.pose = pose.world_from_base * setup.base_from_fisheye;
    events.push_back(e);
  }
}

/// Wheel odometry: dead reckoning on the true planar increments.
void addWheelOdometry(const Setup& setup, std::vector<Event>& events) {
  const Scenario& sc = setup.scenario;
  const std::uint32_t seed = setup.noise_seed;
  const double duration = setup.duration;
  const OdometrySpec& o = sc.robot.odometry;
  std::mt19937 rng(streamSeed(seed, "odometry"));
  const double scale_error = o.scale_error_sigma * gaussian(rng);
  const double yaw_bias = o.yaw_bias_sigma_deg_per_s * kDegree * gaussian(rng);
  const double period = 1 / o.rate_hz;
  Rigid3d previous_true;
  double x = 0, y = 0, yaw = 0, z = 0, previous_t = 0;
  for (std::int64_t j = 0;; ++j) {
    const double t = setup.odometry_phase + static_cast<double>(j) * period;
    if (t > duration) break;
    const Rigid3d world_from_base = setup.motion->worldFromBase(t);
    if (j == 0) {
      x = world_from_base.translation.x();
      y = world_from_base.translation.y();
      z = world_from_base.translation.z();
      yaw = yawOf(world_from_base);
    } else {
      const double previous_yaw = yawOf(previous_true);
      const Eigen::Vector2d delta =
          (world_from_base.translation - previous_true.translation).head<2>();
      const double c = std::cos(previous_yaw), s = std::sin(previous_yaw);
      const double dx = c * delta.x() + s * delta.y();
      const double dy = -s * delta.x() + c * delta.y();
      const double dyaw = wrapAngle(yawOf(world_from_base) - previous_yaw);
      const double distance = delta.norm();
      const double n_distance = gaussian(rng), n_yaw = gaussian(rng);
      const double mdx =
          dx * (1 + scale_error) + o.distance_noise_m_per_sqrt_m * std::sqrt(distance) * n_distance;
      const double mdy = dy * (1 + scale_error);
      const double mdyaw = dyaw + yaw_bias * (t - previous_t) +
                           o.yaw_noise_deg_per_sqrt_m * kDegree * std::sqrt(distance) * n_yaw;
      x += std::cos(yaw) * mdx - std::sin(yaw) * mdy;
      y += std::sin(yaw) * mdx + std::cos(yaw) * mdy;
      yaw = wrapAngle(yaw + mdyaw);
    }
    previous_true = world_from_base;
    previous_t = t;
    Event e;
    e.kind = EventKind::kOdometry;
    e.t = t;
    e.index = j;
    e.stamp = setup.stamp(t, setup.robot_offset);
    e.pose = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                     Eigen::Vector3d(x, y, z)) *
             setup.base_from_fisheye;
    events.push_back(e);
  }
}

/// A floor marker as a MarkerSpec (the robot marker's dictionary).
MarkerSpec floorMarkerSpec(const Scenario& sc, const FloorMarkerSpec& floor) {
  MarkerSpec spec = sc.marker;
  spec.id = floor.id;
  spec.size_m = floor.size_m;
  return spec;
}

Rigid3d worldFromFloorMarker(const FloorMarkerSpec& floor) {
  return Rigid3d(
      Eigen::Quaterniond(Eigen::AngleAxisd(floor.yaw_deg * kDegree, Eigen::Vector3d::UnitZ())),
      floor.position_m);
}

/// The floor markers camera c's frame k detects, each with noise drawn from
/// a stream of its own: adding floor markers to a scenario changes no other
/// draw, so its other detections stay the same.
std::vector<MarkerObservation> simulateFloorMarkers(const Setup& setup, std::size_t c,
                                                    std::int64_t k) {
  const Scenario& sc = setup.scenario;
  const EnvCameraPlacement& placement = setup.placements[c];
  std::vector<MarkerObservation> seen;
  for (const FloorMarkerSpec& floor : sc.floor_markers) {
    const MarkerSpec spec = floorMarkerSpec(sc, floor);
    const Rigid3d camera_from_floor =
        placement.world_from_camera.inverse() * worldFromFloorMarker(floor);
    const auto side = detectableSide(*setup.env_camera, camera_from_floor, spec, sc.noise);
    if (!side) continue;
    std::mt19937 noise(
        itemSeed(setup.noise_seed, "floor/" + placement.label + "/" + std::to_string(floor.id), k));
    std::optional<MarkerObservation> m =
        sc.noise.marker_corners ? markerFromNoisyCorners(*setup.env_camera, camera_from_floor, spec,
                                                         sc.noise.marker_corner_sigma_px, noise)
                                : noisyMarker(camera_from_floor, *side, spec, sc.noise, noise);
    if (!m) continue;
    m->camera = placement.label;
    seen.push_back(*m);
  }
  return seen;
}

/// In detections-only mode, what camera c's frame k detects (into
/// e.marker): the marker, a decoy, or nothing; and (into e.floor_markers)
/// the floor markers it sees. False when nothing.
bool simulateDetection(const Setup& setup, std::size_t c, std::int64_t k,
                       const Rigid3d& world_from_base, Event& e,
                       std::map<std::string, std::int64_t>& fault_counts) {
  const Scenario& sc = setup.scenario;
  const std::uint32_t seed = setup.noise_seed;
  const EnvCameraPlacement& placement = setup.placements[c];
  const Rigid3d camera_from_world = placement.world_from_camera.inverse();
  const Rigid3d camera_from_marker =
      camera_from_world * (world_from_base * setup.base_from_fisheye * setup.fisheye_from_marker);
  const auto side = detectableSide(*setup.env_camera, camera_from_marker, sc.marker, sc.noise);
  std::mt19937 noise(itemSeed(seed, "detect/" + placement.label, k));
  // noise.marker_corners: the pose from noisy corners, drawn from a
  // stream of their own so that every other draw stays as without them.
  auto observe = [&](const Rigid3d& camera_from_seen, double side_px) {
    if (!sc.noise.marker_corners) {
      return std::optional<MarkerObservation>(
          noisyMarker(camera_from_seen, side_px, sc.marker, sc.noise, noise));
    }
    std::mt19937 corner_noise(itemSeed(seed, "corners/" + placement.label, k));
    return markerFromNoisyCorners(*setup.env_camera, camera_from_seen, sc.marker,
                                  sc.noise.marker_corner_sigma_px, corner_noise);
  };
  if (side && !e.occluded) {
    e.marker = observe(camera_from_marker, *side);
  } else if (e.false_marker) {
    // A false detection only where the real marker is not seen (a
    // reader keeps one detection of an id per frame).
    if (const auto decoy =
            decoyWorldFromMarker(*setup.env_camera, placement.world_from_camera, noise)) {
      const Rigid3d camera_from_decoy = camera_from_world * *decoy;
      if (const auto decoy_side =
              detectableSide(*setup.env_camera, camera_from_decoy, sc.marker, sc.noise)) {
        e.marker = observe(camera_from_decoy, *decoy_side);
        if (e.marker) ++fault_counts["false marker detections"];
      }
    }
  }
  if (side && e.occluded) ++fault_counts["occluded marker detections"];
  if (e.marker) {
    e.marker->t = e.stamp;
    e.marker->camera = placement.label;
  }
  e.floor_markers = simulateFloorMarkers(setup, c, k);
  for (MarkerObservation& m : e.floor_markers) m.t = e.stamp;
  return e.marker.has_value() || !e.floor_markers.empty();
}

/// Environment-camera frames while the robot is near, only between the
/// first and the last fisheye frame, so that the ground truth covers every
/// detection.
void addEnvCameraEvents(const Setup& setup, const SimulateOptions& options,
                        std::vector<Event>& events,
                        std::map<std::string, std::int64_t>& fault_counts) {
  const Scenario& sc = setup.scenario;
  const std::uint32_t seed = setup.noise_seed;
  const double duration = setup.duration;
  const double fisheye_period = 1 / sc.robot.fisheye.rate_hz;
  const double first_fisheye = setup.fisheye_phase;
  const double last_fisheye =
      first_fisheye + std::floor((duration - first_fisheye) / fisheye_period) * fisheye_period;
  const double camera_period = 1 / sc.cameras.rate_hz;
  const double radius = sc.cameras.store_radius_m;
  for (size_t c = 0; c < setup.placements.size(); ++c) {
    const EnvCameraPlacement& placement = setup.placements[c];
    const Eigen::Vector2d nadir = placement.world_from_camera.translation.head<2>();
    const std::size_t first_event = events.size();
    for (std::int64_t k = 0;; ++k) {
      const double t = setup.camera_phase[c] + static_cast<double>(k) * camera_period;
      if (t > last_fisheye) break;
      if (t < first_fisheye) continue;
      const Rigid3d world_from_base = setup.motion->worldFromBase(t);
      if ((world_from_base.translation.head<2>() - nadir).norm() > radius) continue;
      std::mt19937 rng(itemSeed(seed, "faults/" + placement.label, k));
      const bool dropped = uniform(rng, 0, 1) < sc.faults.drop_probability;
      Event e;
      e.kind = EventKind::kEnv;
      e.t = t;
      e.camera = static_cast<int>(c);
      e.index = k;
      e.stamp = setup.stamp(t, setup.camera_offsets[c]);
      e.occluded = uniform(rng, 0, 1) < sc.faults.occlusion_probability;
      e.false_marker = uniform(rng, 0, 1) < sc.faults.false_marker_rate;
      e.exposure = setup.camera_gain[c] * (1 + sc.render.exposure_jitter * uniform(rng, -1, 1));
      if (dropped) {
        ++fault_counts["dropped frames"];
        continue;
      }
      if (options.detections_only) {
        if (!simulateDetection(setup, c, k, world_from_base, e, fault_counts)) {
          continue;  // nothing to write for this frame
        }
      } else {
        if (e.occluded) ++fault_counts["occluded marker frames"];
      }
      events.push_back(std::move(e));
    }
    if (options.detections_only && sc.noise.marker_pass_share > 0) {
      sharePassErrors(events, first_event, *setup.env_camera, sc, seed, placement.label);
    }
  }
}

/// Duplicated timestamps: a record takes the stamp of the previous record
/// of its stream (a driver that stamps two frames alike). Image streams
/// only in the folder format (a rawlog cannot hold two frames of one camera
/// at one time: its image files are named by time).
void duplicateTimestamps(const Setup& setup, const SimulateOptions& options,
                         std::vector<Event>& events,
                         std::map<std::string, std::int64_t>& fault_counts) {
  const Scenario& sc = setup.scenario;
  const std::uint32_t seed = setup.noise_seed;
  std::map<std::pair<int, int>, std::vector<size_t>> streams;  // (kind, camera) -> indices
  for (size_t i = 0; i < events.size(); ++i) {
    const Event& e = events[i];
    const bool image =
        !options.detections_only && (e.kind == EventKind::kFisheye || e.kind == EventKind::kEnv);
    if (e.kind == EventKind::kGroundTruth) continue;
    if (image && options.kind == DatasetKind::kRawlog) continue;
    streams[{static_cast<int>(e.kind), e.camera}].push_back(i);
  }
  std::vector<std::pair<size_t, size_t>> candidates;  // (event, previous event of the stream)
  for (const auto& [key, indices] : streams) {
    for (size_t j = 1; j < indices.size(); ++j) candidates.emplace_back(indices[j], indices[j - 1]);
  }
  std::mt19937 rng(streamSeed(seed, "faults/duplicates"));
  std::shuffle(candidates.begin(), candidates.end(), rng);
  std::set<size_t> used;
  int done = 0;
  for (const auto& [i, previous] : candidates) {
    if (done >= sc.faults.duplicated_timestamps) break;
    if (used.count(i) || used.count(previous)) continue;
    used.insert(i);
    used.insert(previous);
    events[i].stamp = events[previous].stamp;
    events[i].duplicated = true;
    if (events[i].marker) events[i].marker->t = events[i].stamp;
    for (MarkerObservation& m : events[i].floor_markers) m.t = events[i].stamp;
    ++done;
  }
  fault_counts["duplicated timestamps"] += done;
  std::stable_sort(events.begin(), events.end(),
                   [](const Event& a, const Event& b) { return a.stamp < b.stamp; });
}

/// Every event of the run, in writing order, with the faults applied.
std::vector<Event> buildEvents(const Setup& setup, const SimulateOptions& options,
                               std::map<std::string, std::int64_t>& fault_counts) {
  std::vector<Event> events;
  addFisheyeEvents(setup, events, fault_counts);
  addReplayedOdometry(setup, events);
  if (setup.replayed_odometry.empty()) addWheelOdometry(setup, events);
  addEnvCameraEvents(setup, options, events, fault_counts);
  auto order = [](const Event& a, const Event& b) {
    if (a.stamp != b.stamp) return a.stamp < b.stamp;
    if (a.kind != b.kind) return a.kind < b.kind;
    if (a.camera != b.camera) return a.camera < b.camera;
    return a.index < b.index;
  };
  std::sort(events.begin(), events.end(), order);
  if (setup.scenario.faults.duplicated_timestamps > 0) {
    duplicateTimestamps(setup, options, events, fault_counts);
  }
  return events;
}

// ---------------------------------------------------------------------------
// Images

std::shared_ptr<const std::vector<std::uint8_t>> encodePng(const cv::Mat& image, int compression) {
  std::vector<uchar> bytes;
  if (!cv::imencode(".png", image, bytes, {cv::IMWRITE_PNG_COMPRESSION, compression}))
    throw Error("cannot encode a rendered frame as PNG");
  return std::make_shared<const std::vector<std::uint8_t>>(bytes.begin(), bytes.end());
}

/// Draws a decoy copy of the marker (lying on the floor) into an env frame:
/// what a false detection in a real image comes from.
void drawDecoy(cv::Mat& image, const Camera& camera, const Rigid3d& camera_from_decoy,
               const MarkerSpec& marker) {
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(
      static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(arucoDictionaryId(marker.dictionary)));
  const int cells = dict->markerSize + 2;  // black border included
  const int cell_px = 16;
  const int quiet = cell_px;  // white margin around the black square, in bitmap pixels
  cv::Mat bitmap;
  cv::aruco::drawMarker(dict, marker.id, cells * cell_px, bitmap, 1);
  cv::copyMakeBorder(bitmap, bitmap, quiet, quiet, quiet, quiet, cv::BORDER_CONSTANT, 255);
  // Bitmap corners (with the white margin) and their projections.
  const double h = 0.5 * marker.size_m * (cells * cell_px + 2.0 * quiet) / (cells * cell_px);
  const Eigen::Vector3d corners[4] = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  const double w = bitmap.cols;
  const cv::Point2f source[4] = {{-0.5f, -0.5f},
                                 {static_cast<float>(w - 0.5), -0.5f},
                                 {static_cast<float>(w - 0.5), static_cast<float>(w - 0.5)},
                                 {-0.5f, static_cast<float>(w - 0.5)}};
  cv::Point2f target[4];
  for (int i = 0; i < 4; ++i) {
    const auto pixel = camera.project(camera_from_decoy * corners[i]);
    if (!pixel) return;
    target[i] = cv::Point2f(static_cast<float>(pixel->x()), static_cast<float>(pixel->y()));
  }
  const cv::Mat homography = cv::getPerspectiveTransform(source, target);
  cv::Mat warped, mask;
  cv::warpPerspective(bitmap, warped, homography, image.size(), cv::INTER_AREA, cv::BORDER_CONSTANT,
                      0);
  cv::Mat ones(bitmap.size(), CV_8UC1, cv::Scalar(255));
  cv::warpPerspective(ones, mask, homography, image.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                      0);
  // A printed copy on the floor: about 70 % as bright as the backlit original.
  cv::Mat blended;
  image.convertTo(blended, CV_32F);
  cv::Mat warped_f, mask_f;
  warped.convertTo(warped_f, CV_32F, 0.7);
  mask.convertTo(mask_f, CV_32F, 1.0 / 255);
  blended = blended.mul(1 - mask_f) + warped_f.mul(mask_f);
  blended.convertTo(image, CV_8U);
}

/// Draws a marker lying on the floor (scenario floor_markers) into an env
/// frame by casting each pixel's rays through the camera's model onto its
/// plane (3x3 per pixel), so that its edges curve as the lens bends them and
/// a detector fitting them through the model finds its true pose. Printed:
/// about 70 % as bright as the backlit robot marker.
void drawFloorMarker(cv::Mat& image, const Camera& camera, const Rigid3d& camera_from_marker,
                     const MarkerSpec& marker) {
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(
      static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(arucoDictionaryId(marker.dictionary)));
  const int cells = dict->markerSize + 2;  // black border included
  const int cell_px = 16, quiet = cell_px;
  cv::Mat bitmap;
  cv::aruco::drawMarker(dict, marker.id, cells * cell_px, bitmap, 1);
  cv::copyMakeBorder(bitmap, bitmap, quiet, quiet, quiet, quiet, cv::BORDER_CONSTANT, 255);
  const double h = 0.5 * marker.size_m * (cells * cell_px + 2.0 * quiet) / (cells * cell_px);
  cv::Rect2d box;
  for (const Eigen::Vector3d& corner : {Eigen::Vector3d(-h, h, 0), Eigen::Vector3d(h, h, 0),
                                        Eigen::Vector3d(h, -h, 0), Eigen::Vector3d(-h, -h, 0)}) {
    const auto pixel = camera.project(camera_from_marker * corner);
    if (!pixel) return;
    box |= cv::Rect2d(pixel->x() - 2, pixel->y() - 2, 4, 4);
  }
  box &= cv::Rect2d(0, 0, image.cols - 1, image.rows - 1);
  const Rigid3d marker_from_camera = camera_from_marker.inverse();
  const double w = bitmap.cols;
  for (int row = static_cast<int>(box.y); row <= static_cast<int>(box.y + box.height); ++row) {
    for (int col = static_cast<int>(box.x); col <= static_cast<int>(box.x + box.width); ++col) {
      double sum = 0;
      int inside = 0;
      for (int sub = 0; sub < 9; ++sub) {
        const Eigen::Vector2d pixel(col + (sub % 3 - 1) / 3.0, row + (sub / 3 - 1) / 3.0);
        const auto ray = camera.unproject(pixel);
        if (!ray) continue;
        const Eigen::Vector3d d = marker_from_camera.rotation * *ray;
        const Eigen::Vector3d& o = marker_from_camera.translation;
        if (d.z() * o.z() >= 0) continue;  // the ray does not reach the marker's plane
        const Eigen::Vector3d p = o - (o.z() / d.z()) * d;
        const double u = (p.x() + h) / (2 * h) * w, v = (h - p.y()) / (2 * h) * w;
        if (u < 0 || v < 0 || u >= w || v >= w) continue;
        sum += bitmap.at<std::uint8_t>(static_cast<int>(v), static_cast<int>(u));
        ++inside;
      }
      if (inside == 0) continue;
      std::uint8_t& out = image.at<std::uint8_t>(row, col);
      out = cv::saturate_cast<std::uint8_t>(out * (9 - inside) / 9.0 + 0.7 * sum / 9.0);
    }
  }
}

/// How the environment cameras' frames are rendered at `exposure`.
RenderOptions envRenderOptions(const Scenario& sc, double exposure) {
  RenderOptions render;
  render.noise_sigma = sc.render.noise_sigma;
  render.exposure = exposure;
  render.supersampling = sc.render.env_supersampling;
  return render;
}

/// A full recording's frames mostly show no robot: each camera's static
/// view is rendered once, at the camera's mean gain, and its frames recast
/// only where the robot can appear.
void renderBackgrounds(Setup& setup, const SimulateOptions& options,
                       const ProgressReporter& progress) {
  const Scenario& sc = setup.scenario;
  if (options.detections_only || !std::isinf(sc.cameras.store_radius_m)) return;
  for (size_t c = 0; c < setup.placements.size(); ++c) {
    progress.checkStop();
    progress.report("simulate: backgrounds", static_cast<std::int64_t>(c),
                    static_cast<std::int64_t>(setup.placements.size()), "");
    setup.backgrounds.push_back(renderEnvBackground(*setup.world, *setup.env_camera,
                                                    setup.placements[c].world_from_camera,
                                                    envRenderOptions(sc, setup.camera_gain[c])));
  }
}

/// The rendered frame of one event (called from several threads); `decoys`
/// counts the false markers drawn.
cv::Mat renderEventImage(const Setup& setup, const Event& e, std::atomic<std::int64_t>& decoys) {
  const Scenario& sc = setup.scenario;
  const std::uint32_t seed = setup.noise_seed;
  const Camera& fisheye = *setup.fisheye;
  const Camera& env = *setup.env_camera;
  const World& world = *setup.world;
  const std::string& fisheye_label = sc.robot.fisheye.label;
  RenderOptions render;
  render.noise_sigma = sc.render.noise_sigma;
  render.exposure = e.exposure;
  cv::Mat image;
  if (e.kind == EventKind::kFisheye) {
    std::mt19937 rng(itemSeed(seed, "render/" + fisheye_label, e.index));
    render.supersampling = sc.render.fisheye_supersampling;
    render.motion_blur_px = e.blur_px;
    image = renderFisheye(world, fisheye, setup.worldFromFisheye(e.t), render, rng);
  } else {
    const EnvCameraPlacement& placement = setup.placements[static_cast<size_t>(e.camera)];
    std::mt19937 rng(itemSeed(seed, "render/" + placement.label, e.index));
    render = envRenderOptions(sc, e.exposure);
    RobotAppearance robot;
    robot.world_from_base = setup.motion->worldFromBase(e.t);
    robot.world_from_marker =
        robot.world_from_base * setup.base_from_fisheye * setup.fisheye_from_marker;
    robot.body_length_m = sc.robot.body_length_m;
    robot.body_width_m = sc.robot.body_width_m;
    robot.body_height_m = sc.robot.body_height_m;
    robot.marker = sc.marker;
    robot.marker_brightness = e.occluded ? 0.0 : 1.0;
    const EnvBackground* background =
        setup.backgrounds.empty() ? nullptr : &setup.backgrounds[static_cast<size_t>(e.camera)];
    image =
        renderEnvCamera(world, env, placement.world_from_camera, robot, render, rng, background);
    if (e.false_marker) {
      std::mt19937 decoy_rng(itemSeed(seed, "detect/" + placement.label, e.index));
      if (const auto decoy = decoyWorldFromMarker(env, placement.world_from_camera, decoy_rng)) {
        const Rigid3d camera_from_decoy = placement.world_from_camera.inverse() * *decoy;
        // Only where it does not cover the robot.
        if ((decoy->translation - robot.world_from_base.translation).head<2>().norm() > 1.0 &&
            detectableSide(env, camera_from_decoy, sc.marker, sc.noise)) {
          drawDecoy(image, env, camera_from_decoy, sc.marker);
          ++decoys;
        }
      }
    }
    for (const FloorMarkerSpec& floor : sc.floor_markers) {
      const MarkerSpec spec = floorMarkerSpec(sc, floor);
      const Rigid3d camera_from_floor =
          placement.world_from_camera.inverse() * worldFromFloorMarker(floor);
      if (detectableSide(env, camera_from_floor, spec, sc.noise)) {
        drawFloorMarker(image, env, camera_from_floor, spec);
      }
    }
  }
  return image;
}

/// What the fisheye's blob detector finds in one frame: every housing in
/// view and not hidden, with noise (the detections-only mode).
BlobObservation simulatedBlobs(const Setup& setup, const Event& e) {
  const Scenario& sc = setup.scenario;
  const Camera& fisheye = *setup.fisheye;
  const World& world = *setup.world;
  const std::string& fisheye_label = sc.robot.fisheye.label;
  BlobObservation obs;
  obs.t = e.stamp;
  obs.camera = fisheye_label;
  obs.image_width = fisheye.width();
  obs.image_height = fisheye.height();
  const Rigid3d world_from_fisheye = setup.worldFromFisheye(e.t);
  const Rigid3d fisheye_from_world = world_from_fisheye.inverse();
  std::mt19937 rng(itemSeed(setup.noise_seed, "detect/" + fisheye_label, e.index));
  const double sigma =
      std::sqrt(sc.noise.blob_sigma_px * sc.noise.blob_sigma_px + e.blur_px * e.blur_px / 12.0);
  for (size_t i = 0; i < world.housings().size(); ++i) {
    const Housing& housing = world.housings()[i];
    const Eigen::Vector3d p = fisheye_from_world * housing.centre_in_world;
    const double n_u = gaussian(rng), n_v = gaussian(rng);  // drawn for every housing
    const auto pixel = fisheye.project(p);
    if (!pixel || !fisheye.isInImage(*pixel, sc.noise.image_margin_px)) continue;
    const Eigen::Vector3d direction =
        (housing.centre_in_world - world_from_fisheye.translation).normalized();
    const Hit hit = world.intersect(world_from_fisheye.translation, direction);
    if (hit.housing != static_cast<int>(i)) continue;  // hidden behind something
    Eigen::Vector3d side = p.cross(Eigen::Vector3d::UnitZ());
    if (side.norm() < 1e-9) side = Eigen::Vector3d::UnitX();
    const auto edge = fisheye.project(p + housing.radius_m * side.normalized());
    Blob blob;
    blob.u = pixel->x() + sigma * n_u;
    blob.v = pixel->y() + sigma * n_v;
    blob.diameter_px = edge ? 2 * (*edge - *pixel).norm() : 0.0;
    blob.response = 1.0;
    obs.blobs.push_back(blob);
  }
  std::sort(obs.blobs.begin(), obs.blobs.end(),
            [](const Blob& a, const Blob& b) { return a.v != b.v ? a.v < b.v : a.u < b.u; });
  return obs;
}

/// The environment cameras' frames as one video per camera (cameras.video),
/// as a recorder keeps them: encoded as they are rendered into a scratch
/// folder beside the output, then handed to the dataset's writer, which
/// links them into the dataset. The scratch folder goes when this does.
class CameraVideos {
 public:
  /// Opens every camera's encoder (a bad codec or preset fails here, before
  /// anything is rendered), in a scratch folder of this process beside `out`.
  CameraVideos(const Setup& setup, const fs::path& out) : setup_(setup) {
    const VideoEncodeOptions options = cameraVideoOptions(setup.scenario.cameras);
    scratch_ = out.parent_path() / ("." + out.filename().string() + ".videos-" +
                                    std::to_string(static_cast<long long>(::getpid())));
    fs::remove_all(scratch_);
    fs::create_directories(scratch_);
    try {
      for (size_t c = 0; c < setup.placements.size(); ++c) {
        encoders_.push_back(std::make_unique<VideoEncoder>(file(static_cast<int>(c)),
                                                           setup.env_camera->width(),
                                                           setup.env_camera->height(), options));
      }
    } catch (...) {
      encoders_.clear();
      std::error_code ec;
      fs::remove_all(scratch_, ec);  // no destructor runs after a throw here
      throw;
    }
    frames_.resize(setup.placements.size());
  }
  ~CameraVideos() {
    encoders_.clear();
    std::error_code ec;
    fs::remove_all(scratch_, ec);
  }
  CameraVideos(const CameraVideos&) = delete;
  CameraVideos& operator=(const CameraVideos&) = delete;

  /// Encodes `image` as the next frame of the camera's video and returns
  /// its index. Safe from several threads for different cameras.
  std::int64_t add(int camera, const cv::Mat& image, double t) {
    VideoEncoder& encoder = *encoders_[static_cast<size_t>(camera)];
    const std::int64_t index = encoder.frames();
    encoder.write(image, std::llround(t * 1e6));
    return index;
  }
  /// Notes that frame `index` of the camera's video was taken at `stamp`.
  void note(int camera, TimeNs stamp, std::int64_t index) {
    frames_[static_cast<size_t>(camera)].emplace_back(stamp, index);
  }
  /// Finishes the videos and writes their frames' records.
  void finish(const std::function<void(const Record&)>& write) {
    for (size_t c = 0; c < encoders_.size(); ++c) {
      if (frames_[c].empty()) continue;  // never in view of the drive: no video
      encoders_[c]->finish();
      for (const auto& [stamp, index] : frames_[c]) {
        ImageFrame frame;
        frame.t = stamp;
        frame.sensor = setup_.placements[c].label;
        frame.video_file = fs::absolute(file(static_cast<int>(c)));
        frame.video_frame = index;
        write(frame);
      }
    }
  }

 private:
  fs::path file(int camera) const {
    return scratch_ / (setup_.placements[static_cast<size_t>(camera)].label + ".mp4");
  }

  const Setup& setup_;
  fs::path scratch_;
  std::vector<std::unique_ptr<VideoEncoder>> encoders_;
  std::vector<std::vector<std::pair<TimeNs, std::int64_t>>> frames_;  ///< (stamp, index).
};

/// What becomes of a rendered frame: its PNG bytes, or null when it went
/// elsewhere (a camera's video).
using FrameSink =
    std::function<std::shared_ptr<const std::vector<std::uint8_t>>(size_t event, const cv::Mat&)>;

/// The frames of `jobs` (indices into `events`) rendered on up to `threads`
/// threads and given to `sink`, by event index.
std::map<size_t, std::shared_ptr<const std::vector<std::uint8_t>>> renderFrames(
    const Setup& setup, const std::vector<Event>& events, const std::vector<size_t>& jobs,
    int threads, const ProgressReporter& progress, std::atomic<std::int64_t>& decoys,
    const FrameSink& sink) {
  std::map<size_t, std::shared_ptr<const std::vector<std::uint8_t>>> images;
  if (jobs.empty()) return images;
  std::vector<std::shared_ptr<const std::vector<std::uint8_t>>> results(jobs.size());
  std::atomic<size_t> next_job{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto worker = [&]() {
    for (size_t j = next_job++; j < jobs.size(); j = next_job++) {
      try {
        if (progress.stopRequested()) return;
        results[j] = sink(jobs[j], renderEventImage(setup, events[jobs[j]], decoys));
      } catch (...) {
        const std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
        return;
      }
    }
  };
  const int n = std::min<int>(threads, static_cast<int>(jobs.size()));
  std::vector<std::thread> pool;
  for (int i = 1; i < n; ++i) pool.emplace_back(worker);
  worker();
  for (std::thread& thread : pool) thread.join();
  if (failure) std::rethrow_exception(failure);
  progress.checkStop();
  for (size_t j = 0; j < jobs.size(); ++j) images[jobs[j]] = results[j];
  return images;
}

/// The next batch of events from `first`: up to the one that completes
/// `max_jobs` render jobs (their indices in `jobs`), and, when the cameras
/// write videos, before a second frame of one camera (a camera's frames are
/// encoded in order). Returns the end of the batch.
size_t nextBatch(const std::vector<Event>& events, size_t first, int max_jobs, bool detections_only,
                 bool videos, std::vector<size_t>& jobs) {
  std::set<int> cameras;
  size_t end = first;
  while (end < events.size() && static_cast<int>(jobs.size()) < max_jobs) {
    const Event& e = events[end];
    if (!detections_only && (e.kind == EventKind::kFisheye || e.kind == EventKind::kEnv)) {
      if (videos && e.kind == EventKind::kEnv && !cameras.insert(e.camera).second) break;
      jobs.push_back(end);
    }
    ++end;
  }
  return end;
}

/// Writes the records of one event; `image` is its rendered frame's PNG bytes.
void writeEvent(const Setup& setup, const SimulateOptions& options, const Event& e,
                const std::shared_ptr<const std::vector<std::uint8_t>>& image,
                const std::function<void(const Record&)>& count) {
  const auto frame = [&](const std::string& sensor) {
    ImageFrame f;
    f.t = e.stamp;
    f.sensor = sensor;
    f.encoded = image;
    f.extension = ".png";
    count(f);
  };
  switch (e.kind) {
    case EventKind::kGroundTruth:
      count(PoseSample{e.stamp, "ground_truth", e.pose});
      break;
    case EventKind::kOdometry:
      count(PoseSample{e.stamp, "odometry", e.pose});
      break;
    case EventKind::kFisheye:
      if (options.detections_only) {
        count(simulatedBlobs(setup, e));
      } else {
        frame(setup.scenario.robot.fisheye.label);
      }
      break;
    case EventKind::kEnv:
      if (options.detections_only) {
        if (e.marker) count(*e.marker);
        for (const MarkerObservation& m : e.floor_markers) count(m);
      } else {
        frame(setup.placements[static_cast<size_t>(e.camera)].label);
      }
      break;
  }
}

}  // namespace

std::string SimulateOptions::check() const {
  if (scenario.empty()) return "'--scenario': empty";
  if (out.empty()) return "'--out': empty";
  if (kind == DatasetKind::kRawlog && out.extension() != ".rawlog")
    return "'--out': a rawlog dataset's path must end in .rawlog, got '" + out.string() + "'";
  if (!(max_duration_s >= 0)) return "'max_duration_s': must not be negative";
  if (threads < 0 || threads > 256) return "'threads': must be in [0, 256]";
  return "";
}

std::int64_t SimulateSummary::total() const {
  std::int64_t n = 0;
  for (const auto& [kind, count] : records) n += count;
  return n;
}

SimulateSummary simulate(const SimulateOptions& options, const ProgressReporter& progress) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  progress.report("simulate: setup", 0, 0, options.scenario);
  Setup mutable_setup = buildSetup(options);
  const Scenario& sc = mutable_setup.scenario;
  const bool videos = sc.cameras.video && !options.detections_only;
  if (videos && options.kind != DatasetKind::kFolder) {
    throw Error(ErrorContext{options.scenario, 0, "cameras.video", ""},
                "videos are written in folder datasets only (--format folder)");
  }
  std::optional<CameraVideos> camera_videos;
  if (videos) camera_videos.emplace(mutable_setup, options.out);
  renderBackgrounds(mutable_setup, options, progress);
  const Setup& setup = mutable_setup;
  progress.checkStop();
  std::map<std::string, std::int64_t> fault_counts;
  std::vector<Event> events = buildEvents(setup, options, fault_counts);
  progress.checkStop();

  const Manifest manifest = buildManifest(setup, options);
  DatasetWriteOptions write_options;
  write_options.overwrite = options.overwrite;
  write_options.link_images = true;  // the videos: linked from the scratch folder, not copied
  std::unique_ptr<DatasetWriter> writer =
      DatasetWriter::create(options.out, options.kind, manifest, write_options);

  SimulateSummary summary;
  summary.cameras = static_cast<int>(setup.placements.size());
  summary.duration_s = setup.duration;
  summary.path_length_m = setup.motion->arcLengthAt(setup.duration);
  summary.seed = setup.seed;
  summary.scenario = sc.name;
  std::atomic<std::int64_t> decoys{0};  // false markers drawn into frames
  auto count = [&](const Record& record) {
    writer->write(record);
    ++summary.records[recordKindName(record)];
  };
  std::vector<std::int64_t> video_frame(events.size(), -1);  // by event
  const FrameSink sink = [&](size_t i, const cv::Mat& image) {
    const Event& e = events[i];
    if (camera_videos && e.kind == EventKind::kEnv) {
      video_frame[i] = camera_videos->add(e.camera, image, e.t);
      return std::shared_ptr<const std::vector<std::uint8_t>>();
    }
    return encodePng(image, sc.render.png_compression);
  };

  const int threads = options.threads > 0
                          ? options.threads
                          : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  const std::int64_t total = static_cast<std::int64_t>(events.size());
  size_t next_event = 0;
  while (next_event < events.size()) {
    progress.checkStop();
    std::vector<size_t> jobs;
    const size_t end = nextBatch(events, next_event, 2 * threads, options.detections_only,
                                 camera_videos.has_value(), jobs);
    const auto images = renderFrames(setup, events, jobs, threads, progress, decoys, sink);
    for (size_t i = next_event; i < end; ++i) {
      const Event& e = events[i];
      if (video_frame[i] >= 0) {
        camera_videos->note(e.camera, e.stamp, video_frame[i]);
        continue;
      }
      const auto image = images.find(i);
      writeEvent(setup, options, e, image == images.end() ? nullptr : image->second, count);
    }
    next_event = end;
    progress.report("simulate", static_cast<std::int64_t>(end), total,
                    options.detections_only ? "detections" : "rendering");
  }
  if (camera_videos) camera_videos->finish(count);
  progress.checkStop();
  writer->finish(manifest);

  if (options.kind == DatasetKind::kRawlog) {
    summary.output_bytes = sizeOf(options.out) + sizeOf(manifestPathFor(options.out)) +
                           sizeOf(imagesDirectoryFor(options.out));
  } else {
    summary.output_bytes = sizeOf(options.out);
  }
  if (decoys > 0) fault_counts["false marker decoys drawn"] = decoys;
  summary.faults = setup.fault_notes;
  for (const auto& [what, n] : fault_counts) {
    if (n > 0) summary.faults.push_back(std::to_string(n) + " " + what);
  }
  return summary;
}

}  // namespace lookboth::sim
