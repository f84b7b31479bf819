// Test fixture: a Registration made from a simulated dataset's ground truth,
// so that the report's tests do not depend on the estimator. Final poses =
// truth; the "look_down" stage pose = truth moved by `before_offset`;
// trajectory = the ground truth trajectory; blob associations = the
// dataset's blobs matched to the truth projection within 8 px, or (for a
// rendered dataset without blobs) the truth projections 1.5 px to the right.
#pragma once

#include <filesystem>

#include "lookboth/dataset/dataset_io.h"
#include "lookboth/registration/registration.h"

namespace lookboth::report::testing {

inline Registration registrationFromTruth(const std::filesystem::path& dataset,
                                          const Eigen::Vector3d& before_offset) {
  auto reader = DatasetReader::open(dataset);
  const Manifest manifest = reader->manifest();
  const Camera& fisheye = *manifest.fisheye()->camera;
  Registration reg;
  reg.dataset = std::filesystem::absolute(dataset).string();
  reg.created = "2026-11-22T12:00:00Z";
  reg.pipeline = {"associate", "motion_calibration", "look_down", "look_up"};
  reg.trajectory_mode = TrajectoryMode::kMetric;
  reg.trajectory_label = "ground_truth";
  reg.fisheye_from_marker = *manifest.ground_truth.fisheye_from_marker;
  std::vector<BlobObservation> blobs;
  std::vector<TimeNs> frame_times;
  while (auto record = reader->next()) {
    if (const auto* pose = std::get_if<PoseSample>(&*record);
        pose && pose->label == "ground_truth") {
      reg.trajectory.push_back({pose->t, pose->world_from_body});
    } else if (const auto* b = std::get_if<BlobObservation>(&*record)) {
      blobs.push_back(*b);
    } else if (const auto* f = std::get_if<ImageFrame>(&*record); f && f->sensor == "fisheye") {
      frame_times.push_back(f->t);
    }
  }
  const Trajectory trajectory(reg.trajectory);
  for (const auto& [label, pose] : manifest.ground_truth.world_from_camera) {
    CameraRegistration c;
    c.label = label;
    c.status = CameraStatus::kRegistered;
    c.world_from_camera = pose;
    Rigid3d before = pose;
    before.translation += before_offset;
    c.stage_poses["look_down"] = before;
    c.stage_poses["look_up"] = pose;
    c.covariance = Matrix6d::Identity() * 1e-6;
    c.detections = {20, 20, 0, 0};
    c.residuals = ResidualStats{0.001, 0.05};
    reg.cameras.push_back(c);
  }
  const auto project = [&](TimeNs t,
                           const Rigid3d& world_from_camera) -> std::optional<Eigen::Vector2d> {
    const InterpolationResult r = trajectory.interpolate(t, 0);
    if (!r.ok()) return std::nullopt;
    const auto uv = fisheye.project(r.world_from_body.inverse() * world_from_camera.translation);
    if (uv && fisheye.isInImage(*uv)) return uv;
    return std::nullopt;
  };
  const auto add = [&](TimeNs t, const CameraRegistration& c, double u, double v) {
    const auto before = project(t, c.stage_poses.at("look_down"));
    const auto after = project(t, c.world_from_camera);
    if (!before || !after) return;
    reg.blob_associations.push_back(
        {t, c.label, u, v, before->x(), before->y(), after->x(), after->y()});
  };
  if (blobs.empty()) {
    for (TimeNs t : frame_times) {
      for (const CameraRegistration& c : reg.cameras) {
        if (const auto after = project(t, c.world_from_camera))
          add(t, c, after->x() + 1.5, after->y());
      }
    }
  } else {
    for (const BlobObservation& b : blobs) {
      for (const Blob& blob : b.blobs) {
        for (const CameraRegistration& c : reg.cameras) {
          const auto after = project(b.t, c.world_from_camera);
          if (after && (*after - Eigen::Vector2d(blob.u, blob.v)).norm() <= 8)
            add(b.t, c, blob.u, blob.v);
        }
      }
    }
  }
  return reg;
}

}  // namespace lookboth::report::testing
