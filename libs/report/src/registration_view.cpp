// The bridge from libs/calib's Registration to what evaluation and pictures need.
#include <cmath>

#include "lookboth/core/error.h"
#include "lookboth/registration/registration.h"
#include "lookboth/report/pose_comparison.h"
#include "lookboth/report/snapshot.h"

namespace lookboth::report {

CameraPoseSet poseSetOfRegistration(const Registration& registration, const std::string& source) {
  CameraPoseSet set;
  set.source = source;
  for (const CameraRegistration& camera : registration.cameras) {
    if (camera.status == CameraStatus::kUnregistered) {
      set.without_pose.push_back(camera.label);
    } else {
      set.world_from_camera[camera.label] = camera.world_from_camera;
      if (camera.aligned_position_covariance)
        set.aligned_position_covariance[camera.label] = *camera.aligned_position_covariance;
    }
  }
  return set;
}

std::vector<ReprojectionRow> reprojectionRows(const Registration& registration) {
  std::vector<ReprojectionRow> rows;
  rows.reserve(registration.blob_associations.size());
  const auto pixel = [](double u, double v) -> std::optional<Eigen::Vector2d> {
    if (!std::isfinite(u) || !std::isfinite(v)) return std::nullopt;
    return Eigen::Vector2d(u, v);
  };
  for (const BlobAssociation& b : registration.blob_associations) {
    rows.push_back(
        {b.t, b.camera, b.u, b.v, pixel(b.u_before, b.v_before), pixel(b.u_after, b.v_after)});
  }
  return rows;
}

RegistrationView viewOfRegistration(const Registration& registration, const std::string& name) {
  RegistrationView view;
  view.name = name;
  for (const CameraRegistration& camera : registration.cameras) {
    if (camera.status == CameraStatus::kUnregistered) {
      view.unregistered.push_back(camera.label);
      continue;
    }
    view.world_from_camera[camera.label] = camera.world_from_camera;
    if (camera.status == CameraStatus::kSuspect) view.suspect.insert(camera.label);
    // "Before refinement" exists only when the looking-up stage ran.
    const auto down = camera.stage_poses.find("look_down");
    if (down != camera.stage_poses.end() && camera.stage_poses.count("look_up")) {
      view.world_from_camera_before[camera.label] = down->second;
    }
  }
  if (!registration.trajectory.empty()) view.trajectory = Trajectory(registration.trajectory);
  view.fisheye_from_marker = registration.fisheye_from_marker;
  view.blob_associations = reprojectionRows(registration);
  return view;
}

std::string EvaluateOptions::check() const {
  if (ground_truth.empty() && against.empty()) {
    return "nothing to compare with: give --ground-truth or --against (or both)";
  }
  return {};
}

Evaluation evaluateRegistration(const std::filesystem::path& registration_dir,
                                const EvaluateOptions& options) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  const Registration registration = loadRegistration(registration_dir);
  Evaluation evaluation;
  evaluation.registration = registration_dir.string();
  const CameraPoseSet estimate = poseSetOfRegistration(registration, registration_dir.string());
  const CompareOptions compare{options.with_scale};
  if (!options.ground_truth.empty()) {
    evaluation.ground_truth =
        comparePoses(loadGroundTruthPoses(options.ground_truth), estimate, compare);
  }
  if (!options.against.empty()) {
    const Registration other = loadRegistration(options.against);
    evaluation.against =
        comparePoses(poseSetOfRegistration(other, options.against.string()), estimate, compare);
  }
  if (!registration.blob_associations.empty()) {
    evaluation.reprojection = reprojectionTable(reprojectionRows(registration));
  }
  if (registration.reprojection) {
    ReprojectionSummary reported;
    reported.blobs = registration.reprojection->blobs;
    reported.rms_px_before = registration.reprojection->rms_px_before;
    reported.rms_px_after = registration.reprojection->rms_px_after;
    evaluation.reported_reprojection = reported;
  }
  return evaluation;
}

}  // namespace lookboth::report
