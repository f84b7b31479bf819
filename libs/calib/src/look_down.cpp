// Stage `look_down` (paper eq. 3): each camera's world_from_camera C from
// its detections M_i (camera_from_marker) and the robot's metric poses
// W_i = F_i(s) X at their times:
//   min_C sum_i rho(|| S_i (C^-1 W_i  [-]  M_i) ||^2),
// the error in the detection's own convention ([dt in the camera frame;
// dtheta in the marker frame]) whitened by S_i, the square root of the
// inverse of (the detection's covariance + the configured robot pose
// noise), with a Huber loss. The start is robust (median of the per-detection
// poses C_i = W_i M_i^-1); detections whose whitened squared residual exceeds
// a chi-square bound are rejected and the camera solved again. The 6x6
// covariance is Ceres' (tangent space = the registration's convention).
#include <algorithm>
#include <cmath>

#include "lookboth/calib/look_down.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "pose_costs.h"

namespace lookboth {
namespace {

using calib_detail::meanRotation;
using calib_detail::sqrtInformation;

constexpr double kDeg = M_PI / 180.0;

struct LookDownCost {
  LookDownCost(const Rigid3d& world_from_marker, const Rigid3d& measured, const Matrix6d& sqrt_info)
      : world_from_marker(world_from_marker), measured(measured), sqrt_info(sqrt_info) {}
  /// Parameter block: world_from_camera [tx ty tz qx qy qz qw]; 6 residuals.
  static ceres::CostFunction* Create(const Rigid3d& world_from_marker, const Rigid3d& measured,
                                     const Matrix6d& sqrt_info) {
    return new ceres::AutoDiffCostFunction<LookDownCost, 6, 7>(
        new LookDownCost(world_from_marker, measured, sqrt_info));
  }
  template <typename T>
  bool operator()(const T* world_from_camera_params, T* residual) const {
    const Rigid3<T> world_from_camera = poseFromParams(world_from_camera_params);
    const Rigid3<T> predicted = world_from_camera.inverse() * world_from_marker.cast<T>();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_info.cast<T>() * poseError(predicted, measured);
    return true;
  }
  Rigid3d world_from_marker, measured;
  Matrix6d sqrt_info;
};

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

void runLookDown(RegistrationProblem& problem, const LookDownOptions& options,
                 const ProgressReporter& progress) {
  if (!problem.associated) {
    throw Error("look_down needs associated detections: put 'associate' before it");
  }
  if (!problem.fisheye_from_marker) {
    throw Error(
        "look_down needs fisheye_from_marker: put 'motion_calibration' (or a stage that sets it) "
        "before it");
  }
  const Rigid3d X = *problem.fisheye_from_marker;
  const double sp = options.robot_position_sigma_m, sr = options.robot_rotation_sigma_deg * kDeg;
  const double dt = options.default_translation_sigma_m,
               dr = options.default_rotation_sigma_deg * kDeg;
  problem.inliers_by_camera.clear();

  // Every camera, in label order (cameras with no association too).
  std::vector<std::string> labels;
  for (const CameraRegistration& c : problem.result.cameras) labels.push_back(c.label);
  std::sort(labels.begin(), labels.end());
  std::int64_t done = 0;
  for (const std::string& label : labels) {
    progress.checkStop();
    progress.report("look_down", done++, static_cast<std::int64_t>(labels.size()), label);
    CameraRegistration& camera = problem.camera(label);
    camera.stage_poses.erase("look_down");
    camera.covariance.reset();
    camera.aligned_position_covariance.reset();
    camera.residuals.reset();
    const auto found = problem.associations_by_camera.find(label);
    const std::vector<std::size_t> none;
    const std::vector<std::size_t>& indices =
        found == problem.associations_by_camera.end() ? none : found->second;
    camera.detections.used = 0;
    camera.detections.rejected = 0;
    const int n = static_cast<int>(indices.size());
    if (n < options.min_detections) {
      camera.status = CameraStatus::kUnregistered;
      if (camera.detections.total == 0) {
        camera.reason = "the robot's marker was never detected by this camera";
      } else if (n == 0) {
        camera.reason = "all " + std::to_string(camera.detections.total) +
                        " detections fall outside the trajectory (or in its gaps)";
      } else {
        camera.reason = "only " + std::to_string(n) + " detections could be associated (at least " +
                        std::to_string(options.min_detections) + " needed)";
      }
      continue;
    }

    // Per detection: the robot's marker pose and the whitening.
    std::vector<Rigid3d> world_from_marker(n);
    std::vector<Matrix6d> sqrt_info(n);
    std::vector<Rigid3d> candidates(n);
    for (int k = 0; k < n; ++k) {
      const Association& a = problem.associations[indices[k]];
      const MarkerObservation& m = problem.marker(a);
      world_from_marker[k] = problem.metricWorldFromFisheye(a.world_from_fisheye) * X;
      candidates[k] = world_from_marker[k] * m.camera_from_marker.inverse();
      Matrix6d cov = Matrix6d::Zero();
      if (m.information.isZero(0)) {
        cov.topLeftCorner<3, 3>().diagonal().setConstant(dt * dt);
        cov.bottomRightCorner<3, 3>().diagonal().setConstant(dr * dr);
      } else {
        const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(
            0.5 * (m.information + m.information.transpose()));
        Eigen::Matrix<double, 6, 1> inv = eig.eigenvalues();
        for (int c = 0; c < 6; ++c) inv[c] = inv[c] > 1e-12 ? 1.0 / inv[c] : 1e12;
        cov = eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
      }
      cov.topLeftCorner<3, 3>().diagonal().array() += sp * sp;
      cov.bottomRightCorner<3, 3>().diagonal().array() += sr * sr;
      sqrt_info[k] = sqrtInformation(cov.inverse());
    }

    // Robust start: component-wise median position, mean rotation of the
    // candidates near it.
    Eigen::Vector3d start_position;
    for (int c = 0; c < 3; ++c) {
      std::vector<double> v(n);
      for (int k = 0; k < n; ++k) v[k] = candidates[k].translation[c];
      start_position[c] = median(v);
    }
    std::vector<double> distances(n);
    for (int k = 0; k < n; ++k) distances[k] = (candidates[k].translation - start_position).norm();
    const double radius = std::max(options.consensus_radius_m, 2.0 * median(distances));
    std::vector<Eigen::Quaterniond> near;
    for (int k = 0; k < n; ++k) {
      if (distances[k] <= radius) near.push_back(candidates[k].rotation);
    }
    Rigid3d estimate(meanRotation(near), start_position);

    std::vector<bool> inlier(n, true);
    double params[7];
    for (int round = 0; round < 4; ++round) {
      // Too few left to fit (none at all would leave the problem empty): the
      // count below marks the camera unregistered with its reason.
      if (std::count(inlier.begin(), inlier.end(), true) < std::max(1, options.min_detections)) {
        break;
      }
      poseToParams(estimate, params);
      ceres::Problem ceres_problem;
      for (int k = 0; k < n; ++k) {
        if (!inlier[k]) continue;
        ceres_problem.AddResidualBlock(
            LookDownCost::Create(
                world_from_marker[k],
                problem.marker(problem.associations[indices[k]]).camera_from_marker, sqrt_info[k]),
            new ceres::HuberLoss(options.huber), params);
      }
      ceres_problem.SetManifold(params, newPoseManifold());
      ceres::Solver::Options solver;
      solver.linear_solver_type = ceres::DENSE_QR;
      solver.max_num_iterations = 50;
      solver.num_threads = 1;
      ceres::Solver::Summary summary;
      ceres::Solve(solver, &ceres_problem, &summary);
      estimate = paramsToPose(params);
      // Reject by the whitened squared residual; stop when nothing changes.
      bool changed = false;
      for (int k = 0; k < n; ++k) {
        const Rigid3d predicted = estimate.inverse() * world_from_marker[k];
        const double chi2 =
            (sqrt_info[k] *
             poseErrorD(predicted,
                        problem.marker(problem.associations[indices[k]]).camera_from_marker))
                .squaredNorm();
        const bool ok = chi2 <= options.reject_chi2;
        if (ok != inlier[k]) changed = true;
        inlier[k] = ok;
      }
      if (!changed) {
        // Covariance of the final fit (tangent space [dt; dtheta], right perturbation).
        ceres::Covariance::Options cov_options;
        cov_options.algorithm_type = ceres::DENSE_SVD;
        cov_options.null_space_rank = -1;
        ceres::Covariance covariance(cov_options);
        std::vector<std::pair<const double*, const double*>> blocks = {{params, params}};
        if (ceres_problem.NumResidualBlocks() > 0 && covariance.Compute(blocks, &ceres_problem)) {
          Matrix6d cov;
          Eigen::Matrix<double, 6, 6, Eigen::RowMajor> row_major;
          covariance.GetCovarianceBlockInTangentSpace(params, params, row_major.data());
          cov = row_major;
          camera.covariance = cov;
          camera.aligned_position_covariance.reset();
        }
        break;
      }
    }

    int used = 0;
    double sum_p = 0, sum_r = 0;
    std::vector<std::size_t>& kept = problem.inliers_by_camera[label];
    for (int k = 0; k < n; ++k) {
      if (!inlier[k]) continue;
      ++used;
      kept.push_back(indices[k]);
      // Eq. 3's residual: the marker's pose seen by the camera vs carried by the robot.
      const Rigid3d by_camera =
          estimate * problem.marker(problem.associations[indices[k]]).camera_from_marker;
      sum_p += (by_camera.translation - world_from_marker[k].translation).squaredNorm();
      const double angle =
          calib_detail::angleOf(by_camera.rotation.conjugate() * world_from_marker[k].rotation);
      sum_r += angle * angle;
    }
    camera.detections.used = used;
    camera.detections.rejected = n - used;
    if (used < options.min_detections) {
      camera.status = CameraStatus::kUnregistered;
      camera.reason = "its detections disagree: only " + std::to_string(used) + " of " +
                      std::to_string(n) + " are consistent with one camera pose";
      camera.covariance.reset();
      camera.aligned_position_covariance.reset();
      continue;
    }
    camera.world_from_camera = estimate;
    camera.stage_poses["look_down"] = estimate;
    camera.residuals = ResidualStats{std::sqrt(sum_p / used), std::sqrt(sum_r / used) / kDeg};
    const double rejected_fraction = static_cast<double>(n - used) / n;
    if (rejected_fraction > options.suspect_rejected_fraction) {
      camera.status = CameraStatus::kSuspect;
      camera.reason = std::to_string(n - used) + " of " + std::to_string(n) +
                      " detections disagree with the rest (outliers, a wrong marker, or a clock "
                      "offset)";
    } else if (used < options.suspect_min_detections) {
      camera.status = CameraStatus::kSuspect;
      camera.reason = "only " + std::to_string(used) + " consistent detections (at least " +
                      std::to_string(options.suspect_min_detections) + " wanted)";
    } else {
      camera.status = CameraStatus::kRegistered;
      camera.reason.clear();
    }
    if (n - used > 0 && camera.status == CameraStatus::kRegistered) {
      camera.notes.push_back(std::to_string(n - used) + " of " + std::to_string(n) +
                             " detections rejected as outliers");
    }
  }
  progress.report("look_down", done, static_cast<std::int64_t>(labels.size()));
}

}  // namespace lookboth
