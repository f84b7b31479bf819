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
  /// Parameter block: the camera's position in the world [m]; 2 residuals [px].
  static ceres::CostFunction* Create(const Camera* fisheye, const Rigid3d& fisheye_from_world,
                                     const Eigen::Vector3d& offset_in_world,
                                     const Eigen::Vector2d& observed) {
    return new ceres::AutoDiffCostFunction<BlobReprojectionCost, 2, 3>(
        new BlobReprojectionCost(fisheye, fisheye_from_world, offset_in_world, observed));
  }
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

// The stage's steps, each a method: the fisheye frames with a pose, the
// cameras to look for, rounds of association and per-camera refinement, and
// the results (positions, covariances, reprojection statistics).
class LookUp {
 public:
  LookUp(RegistrationProblem& problem, const LookUpOptions& options, const Camera& fisheye)
      : problem_(problem), options_(options), fisheye_(fisheye) {}

  void run(const ProgressReporter& progress) {
    collectFrames();
    if (!collectCameras()) return;
    range_ = searchRange();
    for (const Candidate& c : cameras_) initial_.push_back(c.position);
    for (int round = 0; round < options_.rounds; ++round) {
      progress.checkStop();
      progress.report("look_up", round, options_.rounds);
      associate(static_cast<std::size_t>(options_.association_frame_step));
      for (std::size_t k = 0; k < cameras_.size(); ++k) refine(k);
    }
    associate(1);  // the final associations, for the statistics
    writeResults();
    progress.report("look_up", options_.rounds, options_.rounds);
  }

 private:
  struct Candidate {
    CameraRegistration* camera;
    Eigen::Vector3d position;  // current estimate (optical centre)
    Eigen::Vector3d offset_in_world;
    std::vector<Match> matches;
    double gate = 0;  // [px]: options.gate_px, then from the camera's own residuals
    std::optional<Eigen::Matrix3d> position_covariance;  // of the last solve [m^2, world]
  };

  /// Fisheye frames with a pose.
  void collectFrames() {
    const TimeNs max_gap =
        effectiveMaxGap(problem_.input.trajectory, static_cast<TimeNs>(options_.max_gap_s * 1e9));
    for (const BlobObservation& b : problem_.input.blobs) {
      const InterpolationResult pose = problem_.input.trajectory.interpolate(b.t, max_gap);
      if (!pose.ok()) continue;
      frames_.push_back({b.t, problem_.metricWorldFromFisheye(pose.world_from_body).inverse(), &b});
    }
  }

  /// Cameras with a pose, sorted by x for a range query around each frame;
  /// false when there is none.
  bool collectCameras() {
    for (CameraRegistration& c : problem_.result.cameras) {
      if (c.status == CameraStatus::kUnregistered) continue;
      cameras_.push_back({&c,
                          c.world_from_camera.translation,
                          c.world_from_camera.rotation * options_.blob_offset_in_camera_m,
                          {},
                          options_.gate_px,
                          std::nullopt});
    }
    if (cameras_.empty()) return false;
    std::sort(cameras_.begin(), cameras_.end(), [](const Candidate& a, const Candidate& b) {
      return a.position.x() < b.position.x();
    });
    for (const Candidate& c : cameras_) xs_.push_back(c.position.x());
    return true;
  }

  /// Farthest a camera can be seen: from the look_down heights above the
  /// fisheye and the fisheye's field of view (plus a margin). Rays beyond 85
  /// deg from the axis are ignored for the range: a camera there is near the
  /// image border and far away.
  double searchRange() const {
    const double max_angle = std::min(fisheye_.maxIncidenceAngle(), 85.0 * M_PI / 180.0);
    double max_height = 0;
    if (!frames_.empty()) {
      const Eigen::Vector3d o = frames_.front().fisheye_from_world.inverse().translation;
      for (const Candidate& c : cameras_) {
        max_height = std::max(max_height, std::abs(c.position.z() - o.z()));
      }
    }
    return std::max(5.0, (max_height + 1.0) * std::tan(max_angle) + 2.0);
  }

  std::optional<Eigen::Vector2d> project(const Frame& f, const Eigen::Vector3d& p) const {
    const Eigen::Vector3d p_in_fisheye = f.fisheye_from_world * p;
    if (p_in_fisheye.z() <= 0) return std::nullopt;
    return fisheye_.project(p_in_fisheye);
  }

  /// Each camera's projection to the nearest blob within the gate,
  /// unambiguous (second nearest blob ambiguity_ratio times farther) and not
  /// claimed by another camera. Rounds associate on every
  /// association_frame_step-th frame (consecutive fisheye frames see nearly
  /// the same thing); the final association uses all.
  void associate(std::size_t frame_step) {
    for (Candidate& c : cameras_) c.matches.clear();
    std::vector<std::pair<std::size_t, Eigen::Vector2d>> projected;  // (camera, pixel)
    calib_detail::BlobsByColumn by_column;
    for (std::size_t fi = 0; fi < frames_.size(); fi += frame_step) {
      const Frame& f = frames_[fi];
      const std::vector<Blob>& blobs = f.blobs->blobs;
      if (blobs.empty()) continue;
      const Eigen::Vector3d o = f.fisheye_from_world.inverse().translation;
      const auto lo = std::lower_bound(xs_.begin(), xs_.end(), o.x() - range_) - xs_.begin();
      const auto hi = std::upper_bound(xs_.begin(), xs_.end(), o.x() + range_) - xs_.begin();
      projected.clear();
      for (auto k = lo; k < hi; ++k) {
        const Candidate& c = cameras_[static_cast<std::size_t>(k)];
        if (std::abs(c.position.y() - o.y()) > range_) continue;
        const auto pixel = project(f, c.position + c.offset_in_world);
        if (!pixel || !fisheye_.isInImage(*pixel, -options_.gate_px)) continue;
        projected.emplace_back(static_cast<std::size_t>(k), *pixel);
      }
      if (projected.empty()) continue;
      by_column.assign(blobs);
      for (const auto& [k, pixel] : projected) {
        if (const auto best = calib_detail::associatedBlob(by_column, k, pixel, cameras_[k].gate,
                                                           options_.ambiguity_ratio, projected)) {
          cameras_[k].matches.push_back({fi, *best});
        }
      }
    }
  }

  /// RMS reprojection error [px] of a camera's matches with it at `position`.
  double rms(const Candidate& c, const Eigen::Vector3d& position) const {
    double sum = 0;
    int count = 0;
    for (const Match& m : c.matches) {
      const Frame& f = frames_[m.frame];
      const auto pixel = project(f, position + c.offset_in_world);
      if (!pixel) continue;
      const Blob& blob = f.blobs->blobs[m.blob];
      sum += (Eigen::Vector2d(blob.u, blob.v) - *pixel).squaredNorm();
      ++count;
    }
    return count ? std::sqrt(sum / count) : 0.0;
  }

  /// Camera k's position from its matched blobs (Ceres, Cauchy loss), with
  /// its covariance, and its gate for the next association.
  void refine(std::size_t k) {
    Candidate& c = cameras_[k];
    if (static_cast<int>(c.matches.size()) < options_.min_blobs) {
      c.position = initial_[k];
      return;
    }
    double p[3] = {c.position.x(), c.position.y(), c.position.z()};
    ceres::Problem::Options problem_options;
    problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;  // shared, below
    ceres::Problem ceres_problem(problem_options);
    // At most max_blobs_per_camera residuals, evenly spread in time.
    const std::size_t n = c.matches.size();
    const std::size_t keep =
        options_.max_blobs_per_camera > 0
            ? std::min(n, static_cast<std::size_t>(options_.max_blobs_per_camera))
            : n;
    auto* loss = new ceres::CauchyLoss(options_.cauchy_px);
    for (std::size_t q = 0; q < keep; ++q) {
      const Match& m = c.matches[q * n / keep];
      const Frame& f = frames_[m.frame];
      const Blob& blob = f.blobs->blobs[m.blob];
      ceres_problem.AddResidualBlock(
          BlobReprojectionCost::Create(&fisheye_, f.fisheye_from_world, c.offset_in_world,
                                       Eigen::Vector2d(blob.u, blob.v)),
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
    c.gate = std::clamp(4.0 * rms(c, c.position), options_.min_gate_px, options_.gate_px);
  }

  /// Camera k's final position: refined, or look_down's when it had too few
  /// blobs or moved more than max_shift_m (with a note or a warning).
  /// Returns whether it was refined.
  bool settle(std::size_t k, Eigen::Vector3d& final_position) {
    Candidate& c = cameras_[k];
    CameraRegistration& camera = *c.camera;
    const int n = static_cast<int>(c.matches.size());
    final_position = c.position;
    if (n < options_.min_blobs) {
      final_position = initial_[k];
      camera.notes.push_back("look_up: only " + std::to_string(n) +
                             " blobs associated; position of look_down kept");
      return false;
    }
    if ((final_position - initial_[k]).norm() > options_.max_shift_m) {
      camera.warnings.push_back("look_up: refinement moved the camera " +
                                formatFixed((final_position - initial_[k]).norm(), 3) +
                                " m (more than max_shift_m); position of look_down kept");
      final_position = initial_[k];
      return false;
    }
    // The position now rests on the blobs: its block of the covariance is
    // look_up's, uncorrelated with look_down's rotation.
    if (camera.covariance && c.position_covariance) {
      camera.covariance->topLeftCorner<3, 3>() = *c.position_covariance;
      camera.covariance->topRightCorner<3, 3>().setZero();
      camera.covariance->bottomLeftCorner<3, 3>().setZero();
    }
    return true;
  }

  /// Camera k's blob associations with the projections before and after.
  void addBlobAssociations(std::size_t k, const Eigen::Vector3d& final_position) {
    const Candidate& c = cameras_[k];
    for (const Match& m : c.matches) {
      const Frame& f = frames_[m.frame];
      const Blob& blob = f.blobs->blobs[m.blob];
      const auto before = project(f, initial_[k] + c.offset_in_world);
      const auto after = project(f, final_position + c.offset_in_world);
      if (!before || !after) continue;
      problem_.result.blob_associations.push_back(
          {f.t, c.camera->label, blob.u, blob.v, before->x(), before->y(), after->x(), after->y()});
    }
  }

  void writeResults() {
    Registration& result = problem_.result;
    int total_blobs = 0;
    double sum_before = 0, sum_after = 0;
    std::size_t refined = 0;
    for (std::size_t k = 0; k < cameras_.size(); ++k) {
      Candidate& c = cameras_[k];
      CameraRegistration& camera = *c.camera;
      const int n = static_cast<int>(c.matches.size());
      Eigen::Vector3d final_position;
      if (settle(k, final_position)) ++refined;
      ReprojectionStats stats;
      stats.blobs = n;
      stats.rms_px_before = rms(c, initial_[k]);
      stats.rms_px_after = rms(c, final_position);
      if (n > 0) camera.reprojection = stats;
      total_blobs += n;
      sum_before += stats.rms_px_before * stats.rms_px_before * n;
      sum_after += stats.rms_px_after * stats.rms_px_after * n;
      camera.world_from_camera.translation = final_position;
      camera.stage_poses["look_up"] = camera.world_from_camera;
      addBlobAssociations(k, final_position);
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
  }

  RegistrationProblem& problem_;
  const LookUpOptions& options_;
  const Camera& fisheye_;
  std::vector<Frame> frames_;
  std::vector<Candidate> cameras_;
  std::vector<double> xs_;                ///< cameras_' x, ascending.
  double range_ = 0;                      ///< [m] around the fisheye, in x and y.
  std::vector<Eigen::Vector3d> initial_;  ///< look_down's positions.
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
  LookUp(problem, options, fisheye).run(progress);
}

}  // namespace lookboth
