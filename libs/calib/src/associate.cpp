// Stage `associate`: the robot pose at each marker detection, by linear +
// slerp interpolation of the trajectory (Trajectory::interpolate), never
// extrapolated. Detections are stamped in their camera's clock; the robot's
// time is t - clock_offset(camera) (node clock - robot clock, 0 unless configured).
#include <algorithm>

#include "lookboth/calib/associate.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth {
namespace {

/// Dropped detections above these fractions of all are a warning, not a note.
constexpr double kMaxGapFraction = 0.1;      ///< In the trajectory's gaps.
constexpr double kMaxOutsideFraction = 0.5;  ///< Before its start or after its end.

}  // namespace

void runAssociate(RegistrationProblem& problem, const AssociateOptions& options,
                  const ProgressReporter& progress) {
  const RegistrationInput& input = problem.input;
  if (input.trajectory.empty()) {
    throw Error("associate: the trajectory '" + input.trajectory_label + "' has no sample");
  }
  problem.associations.clear();
  problem.associations_by_camera.clear();
  RegistrationStatistics& stats = problem.result.statistics;
  stats.detections_total = 0;
  stats.detections_associated = 0;
  stats.dropped_outside_trajectory = 0;
  stats.dropped_gap = 0;
  std::int64_t other_marker = 0;
  const int marker_id = input.manifest.marker.id;
  const TimeNs max_gap =
      effectiveMaxGap(input.trajectory, static_cast<TimeNs>(options.max_gap_s * 1e9));

  // Every environment camera of the manifest gets an entry, detected or not.
  for (const CameraSensor& sensor : input.manifest.cameras) {
    if (sensor.role == SensorRole::kEnvCamera) problem.camera(sensor.label);
  }
  const std::size_t n = input.markers.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (i % 4096 == 0) {
      progress.checkStop();
      progress.report("associate", static_cast<std::int64_t>(i), static_cast<std::int64_t>(n));
    }
    const MarkerObservation& m = input.markers[i];
    if (m.marker_id != marker_id) {
      ++other_marker;
      continue;
    }
    ++stats.detections_total;
    CameraRegistration& camera = problem.camera(m.camera);
    ++camera.detections.total;
    const auto offset = options.clock_offsets_ns.find(m.camera);
    const TimeNs t_robot = m.t - (offset == options.clock_offsets_ns.end() ? 0 : offset->second);
    const InterpolationResult pose = input.trajectory.interpolate(t_robot, max_gap);
    if (!pose.ok()) {
      ++camera.detections.outside_trajectory;
      if (pose.status == InterpolationStatus::kGapTooLong) {
        ++stats.dropped_gap;
      } else {
        ++stats.dropped_outside_trajectory;
      }
      continue;
    }
    problem.associations.push_back({i, t_robot, pose.world_from_body});
    ++stats.detections_associated;
  }
  // Index by camera, in time order.
  for (std::size_t a = 0; a < problem.associations.size(); ++a) {
    problem.associations_by_camera[problem.marker(problem.associations[a]).camera].push_back(a);
  }
  for (auto& [label, indices] : problem.associations_by_camera) {
    std::stable_sort(indices.begin(), indices.end(), [&](std::size_t a, std::size_t b) {
      return problem.associations[a].t_robot < problem.associations[b].t_robot;
    });
  }
  if (other_marker > 0) {
    problem.result.notes.push_back(std::to_string(other_marker) +
                                   " detections of other marker ids than the robot's (" +
                                   std::to_string(marker_id) + ") ignored");
  }
  const std::int64_t dropped = stats.dropped_outside_trajectory + stats.dropped_gap;
  if (dropped > 0) {
    const std::string text = std::to_string(stats.dropped_outside_trajectory) +
                             " detections outside the trajectory and " +
                             std::to_string(stats.dropped_gap) + " inside its gaps (longer than " +
                             formatDouble(nsToSeconds(max_gap)) +
                             " s) were dropped (never extrapolated)";
    // Detections before the trajectory starts and after it ends are
    // expected: the cameras record the whole drive, the odometry starts
    // late (visual odometry initialises). Gaps mean the odometry lost
    // track; many of either mean the trajectory misses part of the drive.
    const double total = static_cast<double>(stats.detections_total);
    if (stats.dropped_gap > kMaxGapFraction * total ||
        stats.dropped_outside_trajectory > kMaxOutsideFraction * total) {
      problem.result.warnings.push_back(
          text +
          ": the trajectory misses part of the drive; check the odometry (lost track?) and "
          "the clock offsets between the cameras and the robot");
    } else {
      problem.result.notes.push_back(text);
    }
  }
  problem.associated = true;
  progress.report("associate", static_cast<std::int64_t>(n), static_cast<std::int64_t>(n));
}

}  // namespace lookboth
