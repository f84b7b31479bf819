// Stage `joint` (beyond the paper): the joint adjustment of the trajectory,
// fisheye_from_marker, the cameras and their clocks over every detection and
// blob. What it estimates and how: joint_adjustment.h; its steps are the
// methods of JointAdjustment, in joint_setup.cpp, joint_clock_search.cpp,
// joint_rounds.cpp, joint_drift_model.cpp and joint_results.cpp.
#include <cstdlib>

#include "joint_adjustment.h"

namespace lookboth {
namespace joint_detail {

JointAdjustment::JointAdjustment(RegistrationProblem& problem, const JointOptions& options,
                                 const ProgressReporter& progress)
    : problem_(problem),
      options_(options),
      progress_(progress),
      input_(problem.input),
      result_(problem.result) {
  // LOOKBOTH_JOINT_VERBOSE=1: diagnostics on stderr; =2: Ceres' full report of every round.
  const char* verbose_env = std::getenv("LOOKBOTH_JOINT_VERBOSE");
  verbose_ = verbose_env != nullptr;
  verbose_every_round_ = verbose_ && verbose_env[0] == '2';
  visual_ = input_.mode == TrajectoryMode::kVisual;
  scale0_ = problem.scale;
}

void JointAdjustment::run() {
  checkInputs();
  prepareReferenceTrajectory();
  initFisheyeFromMarker();
  buildNodes();
  initCameras();
  collectDetections();
  collectBlobFrames();
  startFromEarlierRun();
  configureSolver();
  solveRounds();
  noteModelEstimates();
  countDetections();
  computeCovariance();
  writeFisheyeFromMarker();
  // Before writeScale changes the problem's scale: the reference between
  // the nodes is scaled as the nodes' own references were (scale0_).
  writeTrajectory();
  writeScale();
  for (std::size_t c = 0; c < cameras_.size(); ++c) writeCamera(c);
  if (use_blobs_) writeReprojection();
  progress_.report("joint", max_rounds_, max_rounds_);
}

double JointAdjustment::lap() {
  const double now = processCpuSeconds();
  const double d = now - cpu_mark_;
  cpu_mark_ = now;
  return d;
}

}  // namespace joint_detail

void runJoint(RegistrationProblem& problem, const JointOptions& options,
              const ProgressReporter& progress) {
  joint_detail::JointAdjustment(problem, options, progress).run();
}

}  // namespace lookboth
