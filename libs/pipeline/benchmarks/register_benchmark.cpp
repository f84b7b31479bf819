// Registration alone (detections and trajectory in memory) on synthetic
// facilities of N cameras along a loop of 3.5 N metres, paper-like noise:
// time of RegistrationController::run and peak memory (run one size per
// process to read its peak: --benchmark_filter=/100$ etc.). doc/benchmarks.md.
#include <benchmark/benchmark.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "../tests/synthetic.h"
#include "lookboth/pipeline/registration_controller.h"

namespace {

using namespace lookboth;

testing::SyntheticScene facility(int cameras) {
  testing::SyntheticOptions o;
  o.cameras = cameras;
  o.loop_length_m = 3.5 * cameras;
  o.speed_mps = 1.0;
  o.fisheye_rate_hz = 10;
  o.camera_rate_hz = 10;
  o.marker_translation_sigma_m = 0.003;
  o.marker_rotation_sigma_deg = 1.0;
  o.blob_sigma_px = 0.7;
  o.seed = 11;
  return testing::makeSyntheticScene(o);
}

// The paper's pipeline (config/paper.yaml) or, joint = true, followed by `joint`.
void registerFacility(benchmark::State& state, bool joint) {
  const int cameras = static_cast<int>(state.range(0));
  const testing::SyntheticScene scene = facility(cameras);
  std::optional<std::filesystem::path> config =
      std::filesystem::path(LOOKBOTH_SHARE_DIR) / "config" / "paper.yaml";
  if (joint) {
    config = std::filesystem::temp_directory_path() /
             ("lookboth-bench-joint-" + std::to_string(::getpid()) + ".yaml");
    // The drift model the doc/benchmarks.md scaling table was measured with;
    // LOOKBOTH_BENCH_JOINT_OPTIONS adds options (YAML flow entries, e.g.
    // "initial_trust_region_radius: 1.0e4") for comparisons.
    const char* extra = std::getenv("LOOKBOTH_BENCH_JOINT_OPTIONS");
    std::ofstream(*config) << "register:\n  pipeline: [associate, motion_calibration, look_down, "
                              "look_up, joint]\n  joint: {drift_m_per_sqrt_m: 0.002, "
                              "drift_deg_per_sqrt_m: 0.05"
                           << (extra != nullptr && *extra ? std::string(", ") + extra : "")
                           << "}\n";
  }
  const RegistrationController controller(loadRegistrationConfig(config));
  if (joint) std::filesystem::remove(*config);
  int registered = 0;
  double position_rmse = 0, aligned_rmse = 0, clock_rms_ms = 0, clock_max_ms = 0;
  for (auto _ : state) {
    const RegistrationRun run = controller.run(scene.input, ProgressReporter());
    registered = run.registration.registeredCount();
    position_rmse =
        testing::accuracyAgainst(run.registration, scene.world_from_camera).position_rmse_m;
    aligned_rmse =
        testing::alignedAccuracy(run.registration, scene.world_from_camera).position_rmse_m;
    // The scene's clocks are all the robot's: an estimated offset is its error.
    double sum = 0;
    int n = 0;
    clock_max_ms = 0;
    for (const CameraRegistration& c : run.registration.cameras) {
      if (c.status == CameraStatus::kUnregistered || !c.clock_offset) continue;
      const double e = static_cast<double>(c.clock_offset->offset_ns) * 1e-6;
      sum += e * e;
      clock_max_ms = std::max(clock_max_ms, std::abs(e));
      ++n;
    }
    clock_rms_ms = n > 0 ? std::sqrt(sum / n) : 0;
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  state.counters["cameras"] = cameras;
  state.counters["registered"] = registered;
  state.counters["markers"] = static_cast<double>(scene.input.markers.size());
  state.counters["blob_frames"] = static_cast<double>(scene.input.blobs.size());
  state.counters["position_rmse_mm"] = position_rmse * 1000;
  state.counters["aligned_rmse_mm"] = aligned_rmse * 1000;
  state.counters["clock_rms_ms"] = clock_rms_ms;
  state.counters["clock_max_ms"] = clock_max_ms;
  state.counters["peak_rss_MiB"] = static_cast<double>(usage.ru_maxrss) / 1024.0;
}
void BM_RegisterFacility(benchmark::State& state) { registerFacility(state, false); }
void BM_RegisterFacilityJoint(benchmark::State& state) { registerFacility(state, true); }
BENCHMARK(BM_RegisterFacilityJoint)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK(BM_RegisterFacility)
    ->Arg(100)
    ->Arg(300)
    ->Arg(1000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
