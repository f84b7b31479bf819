// The motion-based calibration (stage motion_calibration, metric mode: scale
// fixed) against a peer, OpenCV's cv::calibrateHandEye (Park's method), on the
// same detections of one camera under which the robot drives on a rolling
// floor (8 deg roll/pitch, so that the mount is determined for both), with
// paper-like marker noise. Counters: error of fisheye_from_marker.
#include <benchmark/benchmark.h>

#include <Eigen/Core>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "../tests/synthetic.h"
#include "lookboth/calib/associate.h"
#include "lookboth/calib/motion_calibration.h"
#include "lookboth/geometry/lie.h"

namespace {

using namespace lookboth;

const testing::SyntheticScene& scene() {
  static const testing::SyntheticScene s = [] {
    testing::SyntheticOptions o;
    o.cameras = 1;
    o.loop_length_m = 12;
    o.laps = 4;
    o.roll_pitch_amplitude_deg = 8;
    o.detection_radius_m = 3.0;
    o.marker_translation_sigma_m = 0.003;
    o.marker_rotation_sigma_deg = 1.0;
    o.seed = 5;
    return testing::makeSyntheticScene(o);
  }();
  return s;
}

void setErrors(benchmark::State& state, const Rigid3d& x) {
  const Rigid3d& truth = scene().fisheye_from_marker;
  state.counters["t_err_mm"] = (x.translation - truth.translation).norm() * 1000;
  state.counters["r_err_deg"] =
      so3Log(Eigen::Quaterniond(truth.rotation.conjugate() * x.rotation)).norm() * 180 / M_PI;
  state.counters["detections"] = static_cast<double>(scene().input.markers.size());
}

void BM_LookbothMotionCalibration(benchmark::State& state) {
  RegistrationProblem base;
  base.input = scene().input;
  runAssociate(base, {}, ProgressReporter());
  MotionCalibrationOptions options;
  options.sigma_translation_m = 0.003;
  Rigid3d x;
  for (auto _ : state) {
    RegistrationProblem problem = base;
    runMotionCalibration(problem, options, ProgressReporter());
    x = *problem.fisheye_from_marker;
  }
  setErrors(state, x);
}
BENCHMARK(BM_LookbothMotionCalibration)->Unit(benchmark::kMillisecond);

void BM_OpenCvCalibrateHandEyePark(benchmark::State& state) {
  // gripper = fisheye, base = world, target = the environment camera, cam = the marker:
  // base_from_gripper = F_i, cam_from_target = M_i^-1; the result is gripper_from_cam = X.
  std::vector<cv::Mat> r_g2b, t_g2b, r_t2c, t_t2c;
  const Trajectory& trajectory = scene().input.trajectory;
  for (const MarkerObservation& m : scene().input.markers) {
    const InterpolationResult f = trajectory.interpolate(m.t, 0);
    if (!f.ok()) continue;
    const Rigid3d target2cam = m.camera_from_marker.inverse();
    cv::Mat r, t;
    cv::eigen2cv(Eigen::Matrix3d(f.world_from_body.rotation.toRotationMatrix()), r);
    cv::eigen2cv(Eigen::Vector3d(f.world_from_body.translation), t);
    r_g2b.push_back(r.clone());
    t_g2b.push_back(t.clone());
    cv::eigen2cv(Eigen::Matrix3d(target2cam.rotation.toRotationMatrix()), r);
    cv::eigen2cv(Eigen::Vector3d(target2cam.translation), t);
    r_t2c.push_back(r.clone());
    t_t2c.push_back(t.clone());
  }
  cv::Mat r_c2g, t_c2g;
  for (auto _ : state) {
    cv::calibrateHandEye(r_g2b, t_g2b, r_t2c, t_t2c, r_c2g, t_c2g, cv::CALIB_HAND_EYE_PARK);
  }
  Eigen::Matrix3d r;
  Eigen::Vector3d t;
  cv::cv2eigen(r_c2g, r);
  cv::cv2eigen(t_c2g, t);
  setErrors(state, Rigid3d(Eigen::Quaterniond(r).normalized(), t));
}
BENCHMARK(BM_OpenCvCalibrateHandEyePark)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
