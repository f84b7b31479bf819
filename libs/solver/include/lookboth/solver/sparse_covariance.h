// Covariances of chosen parameter blocks of a solved Ceres problem,
// from the Gauss-Newton information H = J^T J at the solution (tangent space
// of each block's manifold, robust losses applied as in the solve; constant
// blocks are held, as by ceres::Covariance).
//
// The columns of H are split into a sparse part A and a small dense group G
// ordered last: G holds the requested blocks that touch many others (for the
// joint stage fisheye_from_marker) and both blocks of every requested pair
// that H does not couple (the scales' pairs). With A = L D L^T (a sparse
// LDL^T, approximate minimum degree on the block graph), W = A^-1 H_AG and
// S = H_GG - H_GA W:
//   cov_GG = S^-1,  cov_AG = -W S^-1,  cov_AA = A^-1 + W S^-1 W^T,
// where only the entries of A^-1 on the pattern of L are computed, by the
// Takahashi recursion (selected inversion). That pattern holds every pair of
// blocks H couples, so each camera's block and its camera x clock block; the
// work and memory grow like the factorisation's, near-linearly in cameras
// for the joint stage, instead of a dense matrix over all requested columns.
// The older route, every requested block in G and A the rest (a Schur
// complement, nothing to invert selectively), is kept as Method::kSchur for
// comparisons: it is no faster on `paper_det` (43 cameras) and grows like
// the cube of the requested columns (doc/benchmarks.md, "The covariance by selected inversion").
//
// The information must be positive definite: a pivot of D or of S below
// 1e-14 of the largest (a direction the data does not determine) makes
// compute() return false, like ceres::Covariance's rank check.
#pragma once
#include <ceres/problem.h>

#include <Eigen/Core>
#include <cstddef>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace lookboth {

class SparseCovariance {
 public:
  enum class Method {
    kSelectedInversion,  ///< only the blocks that must be dense; selected inversion of the rest
    kSchur,              ///< every requested block dense (the older route; for comparisons)
  };

  /// Covariance blocks (a, b) to compute; both blocks must be in `problem`
  /// and not constant. Returns false (and message()) when the information is
  /// singular or not finite.
  bool compute(const std::vector<std::pair<const double*, const double*>>& pairs,
               ceres::Problem* problem, int threads = 1,
               Method method = Method::kSelectedInversion);
  /// Tangent-space block (tangent size of a x tangent size of b); requires a
  /// pair given to compute() (either order).
  Eigen::MatrixXd block(const double* a, const double* b) const;
  const std::string& message() const { return message_; }
  /// compute() fails (with message()) rather than hold more dense entries
  /// than this: W = A^-1 B over the requested sparse blocks and the dense
  /// group, twice, and S (default 2^26 doubles, 512 MiB).
  void setMaxDenseEntries(std::size_t entries) { max_dense_entries_ = entries; }

  /// Before compute(): also keep H^-1's whole columns of these blocks, for a
  /// sandwich H^-1 M H^-1 whose M reaches every parameter. Each block must end
  /// up in the dense group (both blocks of a requested pair H does not couple,
  /// as the joint stage's camera pairs); the columns cost a dense matrix of
  /// the sparse columns by the dense ones, within setMaxDenseEntries.
  void requestWholeColumns(std::vector<const double*> blocks) {
    whole_request_ = std::move(blocks);
  }
  /// After compute(): those columns side by side (the blocks' tangent sizes,
  /// in the order requested), one row per free tangent coordinate; empty when
  /// they could not be kept (see message()). wholeRow(): where a free block's
  /// rows start in it (-1: constant or not in the problem).
  const Eigen::MatrixXd& wholeColumns() const { return whole_columns_; }
  int wholeRow(const double* block) const;

  /// What the last compute() did (for tests and benchmarks).
  struct Stats {
    Method method = Method::kSelectedInversion;  ///< the route taken
    int sparse_columns = 0;                      ///< columns of A
    int dense_columns = 0;                       ///< columns of G
    long long factor_nonzeros = 0;               ///< strictly lower nonzeros of L
    double evaluate_cpu_s = 0;                   ///< process CPU: the Jacobian and J^T J
    double rest_cpu_s = 0;  ///< process CPU: ordering, factorisations, inverses
  };
  const Stats& stats() const { return stats_; }
  /// stats() as " (route ..., columns ..., CPU ...)" for a log line.
  std::string describe() const;

 private:
  std::map<std::pair<const double*, const double*>, Eigen::MatrixXd> blocks_;
  std::vector<const double*> whole_request_;
  Eigen::MatrixXd whole_columns_;
  std::map<const double*, int> whole_row_;
  std::string message_;
  Stats stats_;
  std::size_t max_dense_entries_ = std::size_t(1) << 26;
};

}  // namespace lookboth
