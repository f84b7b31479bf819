#include "sparse_covariance.h"

#include <ceres/crs_matrix.h>

#include <Eigen/Cholesky>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

namespace lookboth::calib_detail {

bool SparseCovariance::compute(const std::vector<std::pair<const double*, const double*>>& pairs,
                               ceres::Problem* problem, int threads) {
  blocks_.clear();
  message_.clear();
  // Columns: the problem's free blocks in its order.
  std::vector<double*> all;
  problem->GetParameterBlocks(&all);
  ceres::Problem::EvaluateOptions evaluate;
  std::map<const double*, std::pair<int, int>> column;  // block -> (first column, tangent size)
  int n = 0;
  for (double* p : all) {
    if (problem->IsParameterBlockConstant(p)) continue;
    const int size = problem->ParameterBlockTangentSize(p);
    evaluate.parameter_blocks.push_back(p);
    column[p] = {n, size};
    n += size;
  }
  for (const auto& [a, b] : pairs) {
    if (!column.count(a) || !column.count(b)) {
      message_ = "a requested block is constant or not in the problem";
      return false;
    }
  }
  if (pairs.empty()) return true;
  evaluate.num_threads = std::max(1, threads);
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(evaluate, nullptr, nullptr, nullptr, &crs)) {
    message_ = "the Jacobian could not be evaluated";
    return false;
  }
  using Sparse = Eigen::SparseMatrix<double>;
  const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor, int>> jacobian(
      crs.num_rows, crs.num_cols, static_cast<int>(crs.values.size()), crs.rows.data(),
      crs.cols.data(), crs.values.data());
  const Sparse jt = Sparse(jacobian.transpose());
  const Sparse information = jt * jacobian;

  // The requested blocks' columns c, the others r. The covariance of c is the
  // inverse of the Schur complement S = H_cc - H_cr H_rr^-1 H_rc: one sparse
  // factorisation of H_rr (the trajectory: banded) and dense products, instead
  // of a sparse factorisation of all of H whose camera rows fill in.
  std::set<const double*> wanted;
  for (const auto& [a, b] : pairs) {
    wanted.insert(a);
    wanted.insert(b);
  }
  std::vector<int> c_index, r_index;  // problem column -> position in c or r
  std::vector<int> place(static_cast<std::size_t>(n), -1);
  std::vector<bool> in_c(static_cast<std::size_t>(n), false);
  std::map<const double*, int> c_first;  // block -> first column in c
  for (double* p : evaluate.parameter_blocks) {
    const auto [first, size] = column[p];
    if (wanted.count(p)) {
      c_first[p] = static_cast<int>(c_index.size());
      for (int k = 0; k < size; ++k) {
        place[first + k] = static_cast<int>(c_index.size());
        in_c[first + k] = true;
        c_index.push_back(first + k);
      }
    } else {
      for (int k = 0; k < size; ++k) {
        place[first + k] = static_cast<int>(r_index.size());
        r_index.push_back(first + k);
      }
    }
  }
  const int m = static_cast<int>(c_index.size()), nr = static_cast<int>(r_index.size());
  std::vector<Eigen::Triplet<double>> rr, rc;
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(m, m);
  for (int col = 0; col < information.outerSize(); ++col) {
    for (Sparse::InnerIterator it(information, col); it; ++it) {
      const int row = static_cast<int>(it.row());
      const int pr = place[row], pc = place[col];
      if (in_c[row] && in_c[col]) {
        s(pr, pc) = it.value();
      } else if (!in_c[row] && !in_c[col]) {
        rr.emplace_back(pr, pc, it.value());
      } else if (!in_c[row]) {
        rc.emplace_back(pr, pc, it.value());  // H_rc: rows r, columns c
      }
    }
  }
  if (nr > 0) {
    Sparse h_rr(nr, nr), h_rc(nr, m);
    h_rr.setFromTriplets(rr.begin(), rr.end());
    h_rc.setFromTriplets(rc.begin(), rc.end());
    Eigen::SimplicialLDLT<Sparse> ldlt(h_rr);
    if (ldlt.info() != Eigen::Success) {
      message_ = "the information matrix could not be factorised";
      return false;
    }
    const Eigen::VectorXd d = ldlt.vectorD();
    const double largest = d.cwiseAbs().maxCoeff();
    if (!std::isfinite(largest) || largest <= 0 || d.minCoeff() <= 1e-14 * largest) {
      message_ = "the information matrix is singular (a direction the data does not determine)";
      return false;
    }
    // S -= H_cr (H_rr^-1 H_rc), by batches of columns.
    constexpr int kBatch = 256;
    for (int first = 0; first < m; first += kBatch) {
      const int width = std::min(kBatch, m - first);
      const Eigen::MatrixXd y = ldlt.solve(Eigen::MatrixXd(h_rc.middleCols(first, width)));
      s.middleCols(first, width).noalias() -= h_rc.transpose() * y;
    }
  }
  s = 0.5 * (s + s.transpose());
  const Eigen::LDLT<Eigen::MatrixXd> s_ldlt(s);
  const Eigen::VectorXd sd = s_ldlt.vectorD();
  const double s_largest = m > 0 ? sd.cwiseAbs().maxCoeff() : 1.0;
  if (s_ldlt.info() != Eigen::Success || !std::isfinite(s_largest) || s_largest <= 0 ||
      (m > 0 && sd.minCoeff() <= 1e-14 * s_largest)) {
    message_ = "the information matrix is singular (a direction the data does not determine)";
    return false;
  }
  const Eigen::MatrixXd cov = s_ldlt.solve(Eigen::MatrixXd::Identity(m, m));
  for (const auto& [a, b] : pairs) {
    blocks_[{a, b}] = cov.block(c_first[a], c_first[b], column[a].second, column[b].second);
  }
  return true;
}

Eigen::MatrixXd SparseCovariance::block(const double* a, const double* b) const {
  if (const auto f = blocks_.find({a, b}); f != blocks_.end()) return f->second;
  if (const auto f = blocks_.find({b, a}); f != blocks_.end()) return f->second.transpose();
  throw std::invalid_argument("SparseCovariance: block not computed");
}

}  // namespace lookboth::calib_detail
