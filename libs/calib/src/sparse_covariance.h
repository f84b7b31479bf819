// Private: covariances of chosen parameter blocks of a solved Ceres problem,
// from the Gauss-Newton information J^T J at the solution (tangent space of
// each block's manifold, robust losses applied as in the solve; constant
// blocks are held, as by ceres::Covariance).
//
// The covariance of the requested blocks is the inverse of the Schur
// complement of the others (for the joint stage: the trajectory, whose
// information is banded) in J^T J: one sparse LDL^T of the eliminated part,
// dense products and one dense LDL^T of size "requested columns". For the
// joint stage on `paper` (43 cameras, 1,930 nodes) ceres::Covariance's
// SPARSE_QR and a sparse LDL^T of all of J^T J each took seconds (the camera
// rows fill in). The information must be positive definite: a pivot below
// 1e-14 of the largest (a direction the data does not determine) makes
// compute() return false, like ceres::Covariance's rank check.
#pragma once
#include <ceres/problem.h>

#include <Eigen/Core>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace lookboth::calib_detail {

class SparseCovariance {
 public:
  /// Covariance blocks (a, b) to compute; both blocks must be in `problem`
  /// and not constant. Returns false (and message()) when the information is
  /// singular or not finite.
  bool compute(const std::vector<std::pair<const double*, const double*>>& pairs,
               ceres::Problem* problem, int threads = 1);
  /// Tangent-space block (tangent size of a x tangent size of b); requires a
  /// pair given to compute() (either order).
  Eigen::MatrixXd block(const double* a, const double* b) const;
  const std::string& message() const { return message_; }

 private:
  std::map<std::pair<const double*, const double*>, Eigen::MatrixXd> blocks_;
  std::string message_;
};

}  // namespace lookboth::calib_detail
