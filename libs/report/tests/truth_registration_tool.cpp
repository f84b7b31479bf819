// Test tool: writes a registration directory made from a simulated dataset's
// ground truth (truth_registration.h), for end-to-end tests and benchmarks of
// evaluate/snapshot/report that must not depend on the estimator.
//   report_truth_registration <dataset> <out dir> [dx dy dz]
// dx dy dz: offset of the "look_down" (before refinement) positions [m].
#include <cstdlib>
#include <iostream>

#include "lookboth/core/error.h"
#include "truth_registration.h"

int main(int argc, char** argv) {
  if (argc != 3 && argc != 6) {
    std::cerr << "usage: " << argv[0] << " <dataset> <out dir> [dx dy dz]\n";
    return 2;
  }
  try {
    Eigen::Vector3d offset(0.1, -0.05, 0.05);
    if (argc == 6)
      offset = Eigen::Vector3d(std::atof(argv[3]), std::atof(argv[4]), std::atof(argv[5]));
    const lookboth::Registration registration =
        lookboth::report::testing::registrationFromTruth(argv[1], offset);
    lookboth::saveRegistration(registration, argv[2]);
    std::cout << "wrote " << argv[2] << ": " << registration.cameras.size() << " cameras, "
              << registration.blob_associations.size() << " blob associations\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
