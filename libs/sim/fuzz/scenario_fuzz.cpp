// Fuzz target "scenario": the bytes as a scenario file given to
// `lookboth simulate --scenario file.yaml`, loaded and checked; a scenario
// that passes is simulated for a moment (detections only), which builds
// everything the file describes: cameras, world, loop, camera placement.
#include <cstddef>
#include <cstdint>

#include "lookboth/sim/scenario.h"
#include "lookboth/sim/simulate.h"
#include "lookboth_fuzz.h"

namespace fuzz = lookboth::fuzz;

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  fuzz::installTerminateHandler();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fuzz::fs::path file = fuzz::scratch() / "scenario.yaml";
  fuzz::writeBytes(file, data, size);
  fuzz::expectOnlyLookbothErrors([&] {
    const lookboth::sim::Scenario scenario = lookboth::sim::loadScenario(file.string());
    if (!scenario.check().empty()) return;
    lookboth::sim::SimulateOptions options;
    options.scenario = file.string();
    options.out = fuzz::scratch() / "simulated";
    options.kind = lookboth::DatasetKind::kFolder;
    options.detections_only = true;
    options.overwrite = true;
    options.max_duration_s = 0.2;
    options.threads = 1;
    (void)lookboth::sim::simulate(options, lookboth::ProgressReporter());
  });
  return 0;
}
