// Stage `look_up` (paper eq. 4-5): refine camera positions p_k by the
// fisheye reprojection error of the blobs (the cameras' housings seen from
// below):  r_kj = [u v]_kj - pi(K, F_j^-1 (p_k + R_k o)),
// with F_j the metric robot pose at fisheye frame j, pi the fisheye's model
// (autodiff through lookboth's templated camera models), o the blob's centre
// in the camera frame (0 in the simulator: its housing dome is centred on the
// optical centre; a real housing sets `blob_offset_in_camera_m`), a Cauchy
// loss, and nearest-neighbour association with a gate and an ambiguity test.
// Rotations are kept (the paper refines positions only). Given the
// trajectory, cameras are independent: each is solved on its own.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <variant>

#include "blob_association.h"
#include "lookboth/calib/look_up.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "pose_costs.h"

namespace lookboth {
namespace {

constexpr std::size_t kMaxParams = 64;

struct BlobReprojectionCost {
  BlobReprojectionCost(const Camera* fisheye, const Rigid3d& fisheye_from_world,
                       const Eigen::Vector3d& offset_in_world, const Eigen::Vector2d& observed)
      : fisheye(fisheye),
        fisheye_from_world(fisheye_from_world),
        offset_in_world(offset_in_world),
        observed(observed) {}
  template <typename T>
  bool operator()(const T* position, T* residual) const {
    const Eigen::Matrix<T, 3, 1> p_in_world =
        Eigen::Matrix<T, 3, 1>(position[0], position[1], position[2]) + offset_in_world.cast<T>();
    const Eigen::Matrix<T, 3, 1> p = fisheye_from_world.cast<T>() * p_in_world;
    // The intrinsics as constants of type T (no allocation per evaluation).
    std::array<T, kMaxParams> params;
    const std::vector<double>& values = fisheye->params();
    for (std::size_t i = 0; i < values.size() && i < kMaxParams; ++i) params[i] = T(values[i]);
    T pixel[2];
    const bool ok =
        std::visit([&](const auto& model) { return model.project(params.data(), p.data(), pixel); },
                   fisheye->model());
    if (!ok) return false;
    residual[0] = T(observed.x()) - pixel[0];
    residual[1] = T(observed.y()) - pixel[1];
    return true;
  }
  const Camera* fisheye;
  Rigid3d fisheye_from_world;
  Eigen::Vector3d offset_in_world;
  Eigen::Vector2d observed;
};

struct Frame {
  TimeNs t = 0;
  Rigid3d fisheye_from_world;  // metric
  const BlobObservation* blobs = nullptr;
};

struct Match {
  std::size_t frame = 0;
  std::size_t blob = 0;
};

}  // namespace

void runLookUp(RegistrationProblem& problem, const LookUpOptions& options,
               const ProgressReporter& progress) {
  Registration& result = problem.result;
  const CameraSensor* fisheye_sensor = problem.input.manifest.fisheye();
  if (problem.input.blobs.empty()) {
    result.warnings.push_back(
        "look_up: the dataset has no blob detections in fisheye frames; camera positions are "
        "those of look_down");
    return;
  }
  if (!fisheye_sensor || !fisheye_sensor->camera) {
    result.warnings.push_back(
        "look_up: the dataset has no fisheye calibration; camera positions are those of "
        "look_down");
    return;
  }
  if (!problem.fisheye_from_marker) {
    throw Error("look_up needs the metric trajectory: put 'motion_calibration' before it");
  }
  const Camera& fisheye = *fisheye_sensor->camera;
  if (fisheye.params().size() > kMaxParams) {
    result.warnings.push_back("look_up: the fisheye model has more than " +
                              std::to_string(kMaxParams) +
                              " parameters; camera positions are those of look_down");
    return;
  }
  const TimeNs max_gap = static_cast<TimeNs>(options.max_gap_s * 1e9);

  // Fisheye frames with a pose.
  std::vector<Frame> frames;
  for (const BlobObservation& b : problem.input.blobs) {
    const InterpolationResult pose = problem.input.trajectory.interpolate(b.t, max_gap);
    if (!pose.ok()) continue;
    frames.push_back({b.t, problem.metricWorldFromFisheye(pose.world_from_body).inverse(), &b});
  }

  // Cameras with a pose, sorted by x for a range query around each frame.
  struct Candidate {
    CameraRegistration* camera;
    Eigen::Vector3d position;  // current estimate (optical centre)
    Eigen::Vector3d offset_in_world;
    std::vector<Match> matches;
    double gate = 0;  // [px]: options.gate_px, then from the camera's own residuals
    std::optional<Eigen::Matrix3d> position_covariance;  // of the last solve [m^2, world]
  };
  std::vector<Candidate> cameras;
  for (CameraRegistration& c : result.cameras) {
    if (c.status == CameraStatus::kUnregistered) continue;
    cameras.push_back({&c,
                       c.world_from_camera.translation,
                       c.world_from_camera.rotation * options.blob_offset_in_camera_m,
                       {},
                       options.gate_px,
                       std::nullopt});
  }
  if (cameras.empty()) return;
  std::sort(cameras.begin(), cameras.end(),
            [](const Candidate& a, const Candidate& b) { return a.position.x() < b.position.x(); });
  std::vector<double> xs;
  for (const Candidate& c : cameras) xs.push_back(c.position.x());
  // Farthest a camera can be seen: from the look_down heights above the
  // fisheye and the fisheye's field of view (plus a margin).
  // (Rays beyond 85 deg from the axis are ignored for the range: a camera
  // there is near the image border and far away.)
  const double max_angle = std::min(fisheye.maxIncidenceAngle(), 85.0 * M_PI / 180.0);
  double max_height = 0;
  if (!frames.empty()) {
    const Eigen::Vector3d o = frames.front().fisheye_from_world.inverse().translation;
    for (const Candidate& c : cameras) {
      max_height = std::max(max_height, std::abs(c.position.z() - o.z()));
    }
  }
  const double range = std::max(5.0, (max_height + 1.0) * std::tan(max_angle) + 2.0);

  auto project = [&](const Frame& f, const Eigen::Vector3d& p) -> std::optional<Eigen::Vector2d> {
    const Eigen::Vector3d p_in_fisheye = f.fisheye_from_world * p;
    if (p_in_fisheye.z() <= 0) return std::nullopt;
    return fisheye.project(p_in_fisheye);
  };

  // Association: each camera's projection to the nearest blob within the
  // gate, unambiguous (second nearest blob ambiguity_ratio times farther) and
  // not claimed by another camera.
  // Rounds associate on every association_frame_step-th frame (consecutive
  // fisheye frames see nearly the same thing); the final association uses all.
  auto associate = [&](std::size_t frame_step) {
    for (Candidate& c : cameras) c.matches.clear();
    std::vector<std::pair<std::size_t, Eigen::Vector2d>> projected;  // (camera, pixel)
    calib_detail::BlobsByColumn by_column;
    for (std::size_t fi = 0; fi < frames.size(); fi += frame_step) {
      const Frame& f = frames[fi];
      const std::vector<Blob>& blobs = f.blobs->blobs;
      if (blobs.empty()) continue;
      const Eigen::Vector3d o = f.fisheye_from_world.inverse().translation;
      const auto lo = std::lower_bound(xs.begin(), xs.end(), o.x() - range) - xs.begin();
      const auto hi = std::upper_bound(xs.begin(), xs.end(), o.x() + range) - xs.begin();
      projected.clear();
      for (auto k = lo; k < hi; ++k) {
        const Candidate& c = cameras[static_cast<std::size_t>(k)];
        if (std::abs(c.position.y() - o.y()) > range) continue;
        const auto pixel = project(f, c.position + c.offset_in_world);
        if (!pixel || !fisheye.isInImage(*pixel, -options.gate_px)) continue;
        projected.emplace_back(static_cast<std::size_t>(k), *pixel);
      }
      if (projected.empty()) continue;
      by_column.assign(blobs);
      for (const auto& [k, pixel] : projected) {
        if (const auto best = calib_detail::associatedBlob(by_column, k, pixel, cameras[k].gate,
                                                           options.ambiguity_ratio, projected)) {
          cameras[k].matches.push_back({fi, *best});
        }
      }
    }
  };

  auto rms = [&](const Candidate& c, const Eigen::Vector3d& position) {
    double sum = 0;
    int count = 0;
    for (const Match& m : c.matches) {
      const Frame& f = frames[m.frame];
      const auto pixel = project(f, position + c.offset_in_world);
      if (!pixel) continue;
      const Blob& blob = f.blobs->blobs[m.blob];
      sum += (Eigen::Vector2d(blob.u, blob.v) - *pixel).squaredNorm();
      ++count;
    }
    return count ? std::sqrt(sum / count) : 0.0;
  };

  std::vector<Eigen::Vector3d> initial;
  for (const Candidate& c : cameras) initial.push_back(c.position);
  for (int round = 0; round < options.rounds; ++round) {
    progress.checkStop();
    progress.report("look_up", round, options.rounds);
    associate(static_cast<std::size_t>(options.association_frame_step));
    for (std::size_t k = 0; k < cameras.size(); ++k) {
      Candidate& c = cameras[k];
      if (static_cast<int>(c.matches.size()) < options.min_blobs) {
        c.position = initial[k];
        continue;
      }
      double p[3] = {c.position.x(), c.position.y(), c.position.z()};
      ceres::Problem::Options problem_options;
      problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // shared, below
      ceres::Problem ceres_problem(problem_options);
      // At most max_blobs_per_camera residuals, evenly spread in time.
      const std::size_t n = c.matches.size();
      const std::size_t keep =
          options.max_blobs_per_camera > 0
              ? std::min(n, static_cast<std::size_t>(options.max_blobs_per_camera))
              : n;
      auto* loss = new ceres::CauchyLoss(options.cauchy_px);
      for (std::size_t q = 0; q < keep; ++q) {
        const Match& m = c.matches[q * n / keep];
        const Frame& f = frames[m.frame];
        const Blob& blob = f.blobs->blobs[m.blob];
        ceres_problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<BlobReprojectionCost, 2, 3>(
                new BlobReprojectionCost(&fisheye, f.fisheye_from_world, c.offset_in_world,
                                         Eigen::Vector2d(blob.u, blob.v))),
            loss, p);
      }
      ceres::Solver::Options solver;
      solver.linear_solver_type = ceres::DENSE_QR;
      solver.max_num_iterations = 50;
      solver.num_threads = 1;
      ceres::Solver::Summary summary;
      ceres::Solve(solver, &ceres_problem, &summary);
      // Position covariance (world frame): Ceres' inverse of J^T J at the
      // solution (robust weights included), scaled by the residuals' variance
      // per pixel coordinate estimated from the final cost.
      c.position_covariance.reset();
      const double dof = 2.0 * static_cast<double>(keep) - 3.0;
      ceres::Covariance::Options cov_options;
      ceres::Covariance covariance(cov_options);
      const std::vector<std::pair<const double*, const double*>> blocks = {{p, p}};
      if (dof > 0 && covariance.Compute(blocks, &ceres_problem)) {
        Eigen::Matrix<double, 3, 3, Eigen::RowMajor> cov;
        covariance.GetCovarianceBlock(p, p, cov.data());
        c.position_covariance = Eigen::Matrix3d(cov) * (2.0 * summary.final_cost / dof);
      }
      delete loss;
      c.position = Eigen::Vector3d(p[0], p[1], p[2]);
      // Tighter gate for the next association: 4x this camera's RMS, within [min_gate_px, gate_px].
      c.gate = std::clamp(4.0 * rms(c, c.position), options.min_gate_px, options.gate_px);
    }
  }
  associate(1);  // the final associations, for the statistics

  int total_blobs = 0;
  double sum_before = 0, sum_after = 0;
  std::size_t refined = 0;
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    Candidate& c = cameras[k];
    CameraRegistration& camera = *c.camera;
    const int n = static_cast<int>(c.matches.size());
    Eigen::Vector3d final_position = c.position;
    if (n < options.min_blobs) {
      final_position = initial[k];
      camera.notes.push_back("look_up: only " + std::to_string(n) +
                             " blobs associated; position of look_down kept");
    } else if ((final_position - initial[k]).norm() > options.max_shift_m) {
      camera.warnings.push_back("look_up: refinement moved the camera " +
                                formatFixed((final_position - initial[k]).norm(), 3) +
                                " m (more than max_shift_m); position of look_down kept");
      final_position = initial[k];
    } else {
      ++refined;
      // The position now rests on the blobs: its block of the covariance is
      // look_up's, uncorrelated with look_down's rotation.
      if (camera.covariance && c.position_covariance) {
        camera.covariance->topLeftCorner<3, 3>() = *c.position_covariance;
        camera.covariance->topRightCorner<3, 3>().setZero();
        camera.covariance->bottomLeftCorner<3, 3>().setZero();
      }
    }
    ReprojectionStats stats;
    stats.blobs = n;
    stats.rms_px_before = rms(c, initial[k]);
    stats.rms_px_after = rms(c, final_position);
    if (n > 0) camera.reprojection = stats;
    total_blobs += n;
    sum_before += stats.rms_px_before * stats.rms_px_before * n;
    sum_after += stats.rms_px_after * stats.rms_px_after * n;
    camera.world_from_camera.translation = final_position;
    camera.stage_poses["look_up"] = camera.world_from_camera;
    for (const Match& m : c.matches) {
      const Frame& f = frames[m.frame];
      const Blob& blob = f.blobs->blobs[m.blob];
      const auto before = project(f, initial[k] + c.offset_in_world);
      const auto after = project(f, final_position + c.offset_in_world);
      if (!before || !after) continue;
      result.blob_associations.push_back(
          {f.t, camera.label, blob.u, blob.v, before->x(), before->y(), after->x(), after->y()});
    }
  }
  std::sort(result.blob_associations.begin(), result.blob_associations.end(),
            [](const BlobAssociation& a, const BlobAssociation& b) {
              return a.t != b.t ? a.t < b.t : a.camera < b.camera;
            });
  if (total_blobs > 0) {
    result.reprojection = ReprojectionStats{total_blobs, std::sqrt(sum_before / total_blobs),
                                            std::sqrt(sum_after / total_blobs)};
  }
  if (refined == 0) {
    result.warnings.push_back("look_up: no camera had enough associated blobs to be refined");
  }
  progress.report("look_up", options.rounds, options.rounds);
}

}  // namespace lookboth
