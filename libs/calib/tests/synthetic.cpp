#include "synthetic.h"

#include <cmath>

#include "lookboth/calib/builtin_stages.h"
#include "lookboth/cameras/camera_io.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/random.h"
#include "lookboth/geometry/umeyama.h"

namespace lookboth::testing {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Point and heading at arc length s on a rounded rectangle (length 2w x w, corner radius 1 m).
void loopPoint(double s, double loop, double* x, double* y, double* yaw) {
  const double r = 1.0;
  const double w = (loop - 2 * M_PI * r + 8 * r) / 6.0;  // sides 2w and w
  const double a = 2 * w - 2 * r, b = w - 2 * r;         // straight parts
  const double q = M_PI * r / 2;                         // quarter arc
  s = std::fmod(s, 2 * (a + b) + 4 * q);
  const double segs[8] = {a, q, b, q, a, q, b, q};
  double cx = r, cy = 0, heading = 0;
  for (int k = 0; k < 8; ++k) {
    if (s <= segs[k] || k == 7) {
      if (k % 2 == 0) {
        *x = cx + s * std::cos(heading);
        *y = cy + s * std::sin(heading);
        *yaw = heading;
      } else {
        const double phi = s / r;
        // Centre of the turn is to the left.
        const double ox = cx - r * std::sin(heading), oy = cy + r * std::cos(heading);
        *x = ox + r * std::sin(heading + phi);
        *y = oy - r * std::cos(heading + phi);
        *yaw = heading + phi;
      }
      return;
    }
    s -= segs[k];
    if (k % 2 == 0) {
      cx += segs[k] * std::cos(heading);
      cy += segs[k] * std::sin(heading);
    } else {
      const double ox = cx - r * std::sin(heading), oy = cy + r * std::cos(heading);
      heading += M_PI / 2;
      cx = ox + r * std::sin(heading);
      cy = oy - r * std::cos(heading);
    }
  }
}

Eigen::Quaterniond rpy(double roll, double pitch, double yaw) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                            Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
}

}  // namespace

SyntheticScene makeSyntheticScene(const SyntheticOptions& o) {
  std::mt19937 rng(o.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  SyntheticScene scene;
  RegistrationInput& input = scene.input;
  input.mode = TrajectoryMode::kMetric;
  input.trajectory_label = "ground_truth";
  input.manifest.name = "synthetic";
  input.manifest.marker.id = 7;
  CameraSensor fisheye;
  fisheye.label = "fisheye";
  fisheye.role = SensorRole::kFisheye;
  fisheye.camera =
      loadCamera(std::string(LOOKBOTH_SHARE_DIR) + "/cameras/fisheye_640x360_calib_results.txt");
  input.manifest.cameras.push_back(fisheye);

  scene.fisheye_from_marker = Rigid3d(rpy(0.4 * kDeg, -0.3 * kDeg, o.marker_yaw_deg * kDeg),
                                      Eigen::Vector3d(0.0, -0.15, -0.05));
  // base_from_fisheye: fisheye z up, its y to the robot's front (base x).
  Eigen::Matrix3d m;
  m << 0, 1, 0, -1, 0, 0, 0, 0, 1;
  const Rigid3d base_from_fisheye(Eigen::Quaterniond(m),
                                  Eigen::Vector3d(0.1, 0, o.fisheye_height_m));

  // Trajectory samples at the fisheye rate.
  const double duration = o.laps * o.loop_length_m / o.speed_mps;
  const TimeNs t0 = secondsToNs(1700000000);
  const TimeNs step = static_cast<TimeNs>(1e9 / o.fisheye_rate_hz);
  const double ph1 = uniform(rng) * 6.28, ph2 = uniform(rng) * 6.28;
  for (TimeNs t = 0; t <= static_cast<TimeNs>(duration * 1e9); t += step) {
    const double s = o.speed_mps * nsToSeconds(t);
    double x, y, yaw;
    loopPoint(s, o.loop_length_m, &x, &y, &yaw);
    const double a = o.roll_pitch_amplitude_deg * kDeg;
    const Rigid3d world_from_base(
        rpy(a * std::sin(0.9 * s + ph1), a * std::sin(0.7 * s + ph2), yaw),
        Eigen::Vector3d(x, y, o.height_amplitude_m * std::sin(0.5 * s)));
    scene.truth.push_back({t0 + t, world_from_base * base_from_fisheye});
  }
  input.trajectory = Trajectory(scene.truth);

  // Cameras along the loop, looking down with a random yaw and a small tilt.
  for (int k = 0; k < o.cameras; ++k) {
    const double s = (k + 0.5) * o.loop_length_m / o.cameras;
    double x, y, yaw;
    loopPoint(s, o.loop_length_m, &x, &y, &yaw);
    const Eigen::Quaterniond down(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()));
    const Eigen::Vector3d angles =
        drawVector<3>([&] { return uniform(rng); });  // yaw drawn first, as gcc did
    const Eigen::Quaterniond q = rpy(3 * kDeg * (2 * angles.x() - 1),
                                     3 * kDeg * (2 * angles.y() - 1), 2 * M_PI * angles.z()) *
                                 down;
    const Eigen::Vector3d offset = drawVector<3>([&] { return uniform(rng); });
    const Eigen::Vector3d p(x + 0.4 * (2 * offset.x() - 1), y + 0.4 * (2 * offset.y() - 1),
                            o.ceiling_m + 0.2 * (2 * offset.z() - 1));
    char label[16];
    std::snprintf(label, sizeof(label), "cam%02d", k);
    scene.world_from_camera[label] = Rigid3d(q.normalized(), p);
    CameraSensor sensor;
    sensor.label = label;
    input.manifest.cameras.push_back(sensor);
  }

  // Detections at the cameras' rate (own phase), when the marker is near the nadir.
  const TimeNs camera_step = static_cast<TimeNs>(1e9 / o.camera_rate_hz);
  for (const auto& [label, world_from_camera] : scene.world_from_camera) {
    const TimeNs phase = static_cast<TimeNs>(uniform(rng) * camera_step);
    for (TimeNs t = t0 + phase; t < scene.truth.back().t; t += camera_step) {
      const InterpolationResult pose = input.trajectory.interpolate(t, 0);
      if (!pose.ok()) continue;
      const Rigid3d world_from_marker = pose.world_from_body * scene.fisheye_from_marker;
      const Eigen::Vector3d d = world_from_marker.translation - world_from_camera.translation;
      if (std::hypot(d.x(), d.y()) > o.detection_radius_m) continue;
      MarkerObservation m;
      m.t = t;
      m.camera = label;
      m.marker_id = 7;
      m.camera_from_marker = world_from_camera.inverse() * world_from_marker;
      const double st = o.marker_translation_sigma_m, sr = o.marker_rotation_sigma_deg * kDeg;
      if (st > 0) {
        m.camera_from_marker.translation += st * drawVector<3>([&] { return normal(rng); });
      }
      if (sr > 0) {
        m.camera_from_marker.rotation =
            m.camera_from_marker.rotation *
            so3Exp(Eigen::Vector3d(sr * drawVector<3>([&] { return normal(rng); })));
      }
      const double it = 1.0 / std::pow(st > 0 ? st : 0.001, 2);
      const double ir = 1.0 / std::pow(sr > 0 ? sr : 0.01, 2);
      m.information.diagonal() << it, it, it, ir, ir, ir;
      input.markers.push_back(m);
    }
  }
  std::sort(input.markers.begin(), input.markers.end(),
            [](const MarkerObservation& a, const MarkerObservation& b) { return a.t < b.t; });

  // Blobs: the cameras' optical centres projected into every fisheye frame.
  const Camera& camera = *fisheye.camera;
  for (const StampedPose& sample : scene.truth) {
    BlobObservation b;
    b.t = sample.t;
    b.camera = "fisheye";
    b.image_width = camera.width();
    b.image_height = camera.height();
    const Rigid3d fisheye_from_world = sample.world_from_body.inverse();
    for (const auto& [label, world_from_camera] : scene.world_from_camera) {
      const Eigen::Vector3d d = world_from_camera.translation - sample.world_from_body.translation;
      if (std::hypot(d.x(), d.y()) > 25.0) continue;  // (far: at the image border or outside)
      const Eigen::Vector3d p = fisheye_from_world * world_from_camera.translation;
      const auto pixel = camera.project(p);
      if (!pixel || !camera.isInImage(*pixel, 2)) continue;
      Blob blob;
      blob.u = pixel->x() + o.blob_sigma_px * normal(rng);
      blob.v = pixel->y() + o.blob_sigma_px * normal(rng);
      blob.diameter_px = 8;
      b.blobs.push_back(blob);
    }
    input.blobs.push_back(b);
  }
  input.manifest.ground_truth.world_from_camera = scene.world_from_camera;
  input.manifest.ground_truth.fisheye_from_marker = scene.fisheye_from_marker;
  return scene;
}

Rigid3d makeVisualOdometry(std::vector<StampedPose>& trajectory, double scale,
                           double drift_m_per_sqrt_m, double drift_deg_per_sqrt_m,
                           std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Rigid3d world_from_vo = trajectory.front().world_from_body;
  const Rigid3d vo_from_world = world_from_vo.inverse();
  Eigen::Vector3d drift = Eigen::Vector3d::Zero();
  double drift_yaw = 0;
  Eigen::Vector3d previous = trajectory.front().world_from_body.translation;
  for (StampedPose& p : trajectory) {
    const double d = (p.world_from_body.translation - previous).norm();
    previous = p.world_from_body.translation;
    const Eigen::Vector2d step = drawVector<2>([&] { return normal(rng); });
    drift += drift_m_per_sqrt_m * std::sqrt(d) * Eigen::Vector3d(step.x(), step.y(), 0);
    drift_yaw += drift_deg_per_sqrt_m * M_PI / 180 * std::sqrt(d) * normal(rng);
    Rigid3d vo = vo_from_world * p.world_from_body;
    vo.rotation =
        Eigen::Quaterniond(Eigen::AngleAxisd(drift_yaw, Eigen::Vector3d::UnitZ())) * vo.rotation;
    vo.translation = (vo.translation + drift) / scale;
    p.world_from_body = vo;
  }
  return world_from_vo;
}

Accuracy accuracyAgainst(const Registration& registration,
                         const std::map<std::string, Rigid3d>& world_from_camera,
                         const Rigid3d& truth_from_registration) {
  Accuracy a;
  double sp = 0, sr = 0;
  for (const CameraRegistration& c : registration.cameras) {
    if (c.status == CameraStatus::kUnregistered) continue;
    const auto truth = world_from_camera.find(c.label);
    if (truth == world_from_camera.end()) continue;
    const Rigid3d estimate = truth_from_registration * c.world_from_camera;
    const double dp = (estimate.translation - truth->second.translation).norm();
    const double dr =
        so3Log(Eigen::Quaterniond(truth->second.rotation.conjugate() * estimate.rotation)).norm() *
        180 / M_PI;
    sp += dp * dp;
    sr += dr * dr;
    a.position_max_m = std::max(a.position_max_m, dp);
    a.rotation_max_deg = std::max(a.rotation_max_deg, dr);
    ++a.compared;
  }
  if (a.compared) {
    a.position_rmse_m = std::sqrt(sp / a.compared);
    a.rotation_rmse_deg = std::sqrt(sr / a.compared);
  }
  return a;
}

Accuracy alignedAccuracy(const Registration& registration,
                         const std::map<std::string, Rigid3d>& world_from_camera) {
  std::vector<Rigid3d> estimated, truth;
  for (const CameraRegistration& c : registration.cameras) {
    if (c.status == CameraStatus::kUnregistered) continue;
    const auto t = world_from_camera.find(c.label);
    if (t == world_from_camera.end()) continue;
    estimated.push_back(c.world_from_camera);
    truth.push_back(t->second);
  }
  const auto alignment = alignPoses(estimated, truth, false);
  if (!alignment) return accuracyAgainst(registration, world_from_camera);
  const Sim3d& s = alignment->dst_from_src;
  return accuracyAgainst(registration, world_from_camera, Rigid3d(s.rotation, s.translation));
}

RegistrationProblem stagesBeforeJoint(const SyntheticScene& scene,
                                      const AssociateOptions& associate) {
  RegistrationProblem problem;
  problem.input = scene.input;
  runAssociate(problem, associate, ProgressReporter());
  MotionCalibrationOptions motion;
  motion.prior_translation_m = scene.fisheye_from_marker.translation;
  runMotionCalibration(problem, motion, ProgressReporter());
  runLookDown(problem, {}, ProgressReporter());
  return problem;
}

}  // namespace lookboth::testing
