// The stage "associate": the robot's pose at each detection's time (linear
// interpolation and slerp on the trajectory, never extrapolated; detections in
// a gap or outside the trajectory are dropped and counted).
#pragma once
#include <Eigen/Geometry>
#include <map>
#include <optional>
#include <string>

#include "lookboth/calib/problem.h"
#include "lookboth/calib/stage_registry.h"

namespace lookboth {

struct AssociateOptions {
  /// Largest interval between the two trajectory samples around a detection
  /// across which the pose is interpolated [s]; detections in longer gaps are
  /// dropped. A sparser trajectory (keyframes) gets ten times its median
  /// sampling interval instead (effectiveMaxGap, lookboth/geometry/trajectory.h).
  double max_gap_s = 0.5;
  /// Known clock offsets, node clock minus robot clock, by camera label [ns]
  /// (0 when absent: NTP-synchronised nodes, as in the paper).
  std::map<std::string, TimeNs> clock_offsets_ns;
  /// Sets the options `node` (the configuration's "register.<stage>" section,
  /// named `field` in errors) has; an unknown key is an error.
  void read(const YamlReader& reader, const YAML::Node& node, const std::string& field);
  /// Every option under its key, as read() reads them.
  void write(YAML::Node& node) const;
  std::string check() const;
};

void runAssociate(RegistrationProblem& problem, const AssociateOptions& options,
                  const ProgressReporter& progress);

}  // namespace lookboth
