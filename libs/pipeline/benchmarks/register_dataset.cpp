// lookboth-bench-register: times `RegistrationController::run` on a dataset
// (detections and trajectory already in memory, as "registration alone") and
// prints the accuracy against the dataset's ground truth.
//
//   lookboth-bench-register <dataset> metric [label] [repeats]
//   lookboth-bench-register <dataset> visual <scale> <drift_m_per_sqrt_m> <drift_deg_per_sqrt_m>
//   [repeats] (either with --config=f.yaml: a configuration over
//   share/lookboth/config/default.yaml, and --shift-camera=<label>:<ms>: that
//   camera's detection stamps shifted by <ms> in memory, i.e. its clock off by
//   that much (node - robot); the dataset file is only read; --per-camera: a
//   line per camera, its errors against the truth in the known frame and the
//   sigmas its covariance gives)
//
// visual: a VO trajectory is synthesised from the dataset's "ground_truth"
// (in the first pose's frame, translations divided by <scale>, random-walk drift).
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <iostream>

#include "../tests/synthetic.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/pipeline/registration_controller.h"

using namespace lookboth;

int main(int argc_in, char** argv_in) {
  try {
    // "--config=f.yaml" anywhere: a configuration over the defaults.
    std::optional<std::filesystem::path> config;
    std::string shift_camera;
    double shift_ms = 0;
    bool per_camera = false;
    std::vector<char*> args;
    for (int i = 0; i < argc_in; ++i) {
      const std::string a = argv_in[i];
      if (a == "--per-camera") {
        per_camera = true;
      } else if (a.rfind("--config=", 0) == 0) {
        config = a.substr(9);
      } else if (a.rfind("--shift-camera=", 0) == 0) {
        const std::string v = a.substr(15);
        const auto colon = v.find(':');
        if (colon == std::string::npos) throw Error("--shift-camera=<label>:<ms>");
        shift_camera = v.substr(0, colon);
        shift_ms = std::stod(v.substr(colon + 1));
      } else {
        args.push_back(argv_in[i]);
      }
    }
    const int argc = static_cast<int>(args.size());
    char** argv = args.data();
    if (argc < 3) {
      std::cerr << "usage: " << argv[0] << " <dataset> metric [label] [repeats]\n       " << argv[0]
                << " <dataset> visual <scale> <drift_m_per_sqrt_m> <drift_deg_per_sqrt_m> "
                   "[repeats]\n";
      return 2;
    }
    RegisterOptions options;
    options.dataset = argv[1];
    const std::string mode = argv[2];
    int repeats = 5;
    double scale = 1, drift = 0, yaw_drift = 0;
    if (mode == "metric") {
      options.mode = TrajectoryMode::kMetric;
      options.trajectory_label = argc > 3 ? argv[3] : "odometry";
      if (argc > 4) repeats = std::stoi(argv[4]);
    } else {
      options.mode = TrajectoryMode::kMetric;  // read ground truth, then make VO of it
      options.trajectory_label = "ground_truth";
      if (argc < 6) throw Error("visual needs <scale> <drift_m_per_sqrt_m> <drift_deg_per_sqrt_m>");
      scale = std::stod(argv[3]);
      drift = std::stod(argv[4]);
      yaw_drift = std::stod(argv[5]);
      if (argc > 6) repeats = std::stoi(argv[6]);
    }
    RegistrationInput input = loadRegistrationInput(options, ProgressReporter());
    if (!shift_camera.empty()) {
      int shifted = 0;
      for (MarkerObservation& m : input.markers) {
        if (m.camera != shift_camera) continue;
        m.t += static_cast<TimeNs>(std::llround(shift_ms * 1e6));
        ++shifted;
      }
      std::cout << "shifted " << shifted << " detections of " << shift_camera << " by " << shift_ms
                << " ms\n";
    }
    Rigid3d truth_from_registration;
    if (mode != "metric") {
      std::vector<StampedPose> vo = input.trajectory.samples();
      truth_from_registration = testing::makeVisualOdometry(vo, scale, drift, yaw_drift, 1);
      input.trajectory = Trajectory(vo);
      input.mode = TrajectoryMode::kVisual;
      input.trajectory_label = "vo (synthesised)";
    }
    const RegistrationController controller(loadRegistrationConfig(config));
    std::vector<double> seconds, cpu_seconds;
    RegistrationRun run;
    for (int k = 0; k < repeats; ++k) {
      const auto start = std::chrono::steady_clock::now();
      const std::clock_t cpu_start = std::clock();
      run = controller.run(input, ProgressReporter());
      cpu_seconds.push_back(static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC);
      seconds.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
    std::sort(seconds.begin(), seconds.end());
    std::sort(cpu_seconds.begin(), cpu_seconds.end());
    const Registration& r = run.registration;
    const auto& truth = input.manifest.ground_truth.world_from_camera;
    const auto direct = testing::accuracyAgainst(r, truth, truth_from_registration);
    const auto aligned = testing::alignedAccuracy(r, truth);
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    std::cout << "dataset: " << options.dataset.string() << "  mode: " << mode
              << "  markers: " << input.markers.size() << "  blob frames: " << input.blobs.size()
              << "  trajectory samples: " << input.trajectory.size() << "\n";
    std::cout << "registered: " << r.registeredCount() << " of " << r.cameras.size()
              << "  scale: " << formatDouble(r.scale) << " (true " << formatDouble(scale) << ")\n";
    std::cout << "time of RegistrationController::run over " << repeats << " runs: min "
              << formatFixed(seconds.front(), 3) << " s, median "
              << formatFixed(seconds[seconds.size() / 2], 3) << " s (CPU time: min "
              << formatFixed(cpu_seconds.front(), 3) << " s, median "
              << formatFixed(cpu_seconds[cpu_seconds.size() / 2], 3)
              << " s); stages (wall, last run):";
    for (const auto& [stage, s] : r.statistics.seconds_per_stage) {
      std::cout << " " << stage << " " << formatFixed(s, 3);
    }
    std::cout << "\npeak RSS: " << usage.ru_maxrss / 1024 << " MiB\n";
    std::cout << "accuracy (registration world mapped to truth by the known frame): position RMSE "
              << formatFixed(direct.position_rmse_m * 1000, 2) << " mm (max "
              << formatFixed(direct.position_max_m * 1000, 2) << "), rotation RMSE "
              << formatFixed(direct.rotation_rmse_deg, 3) << " deg (max "
              << formatFixed(direct.rotation_max_deg, 3) << ")\n";
    std::cout << "accuracy after SE(3) Umeyama alignment: position RMSE "
              << formatFixed(aligned.position_rmse_m * 1000, 2) << " mm (max "
              << formatFixed(aligned.position_max_m * 1000, 2) << "), rotation RMSE "
              << formatFixed(aligned.rotation_rmse_deg, 3) << " deg (max "
              << formatFixed(aligned.rotation_max_deg, 3) << ")\n";
    {
      // What the estimate's own covariance predicts for the first line's
      // RMSE (the same gauge): sqrt of the mean trace of the cameras'
      // position covariances.
      double sum = 0;
      int n = 0;
      for (const CameraRegistration& c : r.cameras) {
        if (!c.covariance) continue;
        sum += c.covariance->topLeftCorner<3, 3>().trace();
        ++n;
      }
      if (n > 0) {
        std::cout << "position RMSE predicted by the covariance: "
                  << formatFixed(std::sqrt(sum / n) * 1000, 2) << " mm (" << n << " cameras)\n";
      }
    }
    if (r.observability.aligned_position_rmse_m) {
      std::cout << "position RMSE after SE(3) alignment predicted by the covariance: "
                << formatFixed(*r.observability.aligned_position_rmse_m * 1000, 2) << " mm\n";
    }
    const Rigid3d& x = r.fisheye_from_marker;
    if (input.manifest.ground_truth.fisheye_from_marker) {
      const Rigid3d& gx = *input.manifest.ground_truth.fisheye_from_marker;
      std::cout << "fisheye_from_marker translation error: "
                << formatFixed((x.translation - gx.translation).norm() * 1000, 2)
                << " mm, rotation error "
                << formatFixed(
                       Eigen::AngleAxisd(gx.rotation.conjugate() * x.rotation).angle() * 180 / M_PI,
                       3)
                << " deg\n";
    }
    for (const CameraRegistration& c : r.cameras) {
      if (c.status != CameraStatus::kRegistered) {
        std::cout << c.label << ": " << cameraStatusName(c.status) << ": " << c.reason << "\n";
      }
    }
    // Clock offsets (joint) against the simulator's (plus the shift).
    double sum_clock = 0, max_clock = 0;
    int n_clock = 0;
    for (const CameraRegistration& c : r.cameras) {
      if (!c.clock_offset || c.status == CameraStatus::kUnregistered) continue;
      const auto t = input.manifest.ground_truth.clock_offset.find(c.label);
      if (t == input.manifest.ground_truth.clock_offset.end()) continue;
      const double truth_ms = t->second * 1e-6 + (c.label == shift_camera ? shift_ms : 0.0);
      const double e = c.clock_offset->offset_ns * 1e-6 - truth_ms;
      sum_clock += e * e;
      max_clock = std::max(max_clock, std::abs(e));
      ++n_clock;
    }
    if (n_clock > 0) {
      std::cout << "clock offsets vs the simulator's: RMS error "
                << formatFixed(std::sqrt(sum_clock / n_clock), 3) << " ms, max "
                << formatFixed(max_clock, 3) << " ms over " << n_clock << " cameras\n";
    }
    for (const CameraRegistration& c : r.cameras) {
      if (!c.clock_offset || c.label != shift_camera) continue;
      const auto t = truth.find(c.label);
      const double e = t == truth.end()
                           ? -1
                           : ((truth_from_registration * c.world_from_camera).translation -
                              t->second.translation)
                                 .norm();
      std::cout << "clock offset of " << c.label << ": "
                << formatFixed(c.clock_offset->offset_ns * 1e-6, 3) << " ms +- "
                << formatFixed(c.clock_offset->sigma_ms, 3) << " ms; status "
                << cameraStatusName(c.status) << "; position error " << formatFixed(e * 1000, 2)
                << " mm\n";
    }
    if (per_camera) {
      std::cout << "camera  status        used  position error [mm]  sigma [mm]  rotation error "
                   "[deg]  clock error [ms]  sigma [ms]\n";
      for (const CameraRegistration& c : r.cameras) {
        const auto t = truth.find(c.label);
        if (t == truth.end() || c.status == CameraStatus::kUnregistered) continue;
        const Rigid3d estimate = truth_from_registration * c.world_from_camera;
        const double position = (estimate.translation - t->second.translation).norm();
        const double rotation =
            Eigen::AngleAxisd(t->second.rotation.conjugate() * estimate.rotation).angle() * 180 /
            M_PI;
        const double sigma =
            c.covariance ? std::sqrt(c.covariance->topLeftCorner<3, 3>().trace()) : -1;
        double clock = 0, clock_sigma = -1;
        const auto tc = input.manifest.ground_truth.clock_offset.find(c.label);
        if (c.clock_offset && tc != input.manifest.ground_truth.clock_offset.end()) {
          clock = c.clock_offset->offset_ns * 1e-6 -
                  (tc->second * 1e-6 + (c.label == shift_camera ? shift_ms : 0.0));
          clock_sigma = c.clock_offset->sigma_ms;
        }
        std::cout << c.label << "   " << cameraStatusName(c.status) << "  " << c.detections.used
                  << "  " << formatFixed(position * 1000, 2) << "  " << formatFixed(sigma * 1000, 2)
                  << "  " << formatFixed(rotation, 3) << "  " << formatFixed(clock, 3) << "  "
                  << formatFixed(clock_sigma, 3) << "\n";
      }
    }
    if (r.reprojection) {
      std::cout << "reprojection: " << r.reprojection->blobs << " blobs, RMS "
                << formatFixed(r.reprojection->rms_px_before, 2) << " px before, "
                << formatFixed(r.reprojection->rms_px_after, 2) << " px after\n";
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
