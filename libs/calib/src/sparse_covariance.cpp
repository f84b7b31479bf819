#include "sparse_covariance.h"

#include <ceres/crs_matrix.h>

#include <Eigen/Cholesky>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <ctime>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace lookboth::calib_detail {
namespace {

using Sparse = Eigen::SparseMatrix<double>;
constexpr const char* kSingular =
    "the information matrix is singular (a direction the data does not determine)";

// Pivots all finite and above 1e-14 of the largest.
bool definite(const Eigen::VectorXd& d) {
  if (d.size() == 0) return true;
  const double largest = d.cwiseAbs().maxCoeff();
  return std::isfinite(largest) && largest > 0 && d.minCoeff() > 1e-14 * largest;
}

// The entries of A^-1 on the pattern of the unit lower factor L (A = L D L^T,
// L strictly lower and column-major with sorted rows), by the Takahashi
// recursion from the last column, Z(j+1:n, j) = -Z(j+1:n, j+1:n) L(j+1:n, j)
// and Z(j, j) = 1 / D(j) - L(j+1:n, j)^T Z(j+1:n, j), over supernodes:
// consecutive columns S with one pattern R below them (a parameter block's
// columns, which H couples alike). With L_SS (unit lower) and L_RS their
// rows of L, M = L_SS^-1 and Y = L_RS M:
//   Z_RS = -Z_RR Y,   Z_SS = M^T D_S^-1 M - Y^T Z_RS,
// where Z_RR lies on the pattern already computed: for k in R, column k's
// pattern holds every row of R below k (elimination fills it). Dense blocks
// per supernode instead of an indexed update per column: 6x fewer passes
// over the later columns on pose blocks.
class SelectedInverse {
 public:
  SelectedInverse(const Sparse& l, const Eigen::VectorXd& d)
      : lp_(l.outerIndexPtr()), li_(l.innerIndexPtr()) {
    const int n = static_cast<int>(l.cols());
    const double* lx = l.valuePtr();
    diagonal_.resize(n);
    values_.assign(static_cast<std::size_t>(lp_[n]), 0.0);
    // Supernodes: column j joins j+1 when its first row is j+1 and it holds
    // one row more (its other rows are then those of j+1).
    std::vector<int> start;
    for (int j = 0; j < n;) {
      start.push_back(j);
      while (j + 1 < n && lp_[j + 1] - lp_[j] == lp_[j + 2] - lp_[j + 1] + 1 &&
             li_[lp_[j]] == j + 1) {
        ++j;
      }
      ++j;
    }
    start.push_back(n);
    std::vector<int> slot(static_cast<std::size_t>(n), -1);  // row -> place in R
    Eigen::MatrixXd l_ss, l_rs, z_rr, m, y, z_rs, z_ss;
    for (int sn = static_cast<int>(start.size()) - 2; sn >= 0; --sn) {
      const int f = start[sn], e = start[sn + 1], w = e - f;
      const int* rows = li_ + lp_[e - 1];  // R: the last column's rows
      const int r = lp_[e] - lp_[e - 1];
      l_ss.setIdentity(w, w);
      l_rs.resize(r, w);
      for (int c = 0; c < w; ++c) {
        const int p = lp_[f + c], inside = w - c - 1;
        for (int a = 0; a < inside; ++a) l_ss(c + 1 + a, c) = lx[p + a];
        for (int a = 0; a < r; ++a) l_rs(a, c) = lx[p + inside + a];
      }
      z_rr.resize(r, r);
      for (int a = 0; a < r; ++a) slot[rows[a]] = a;
      for (int a = 0; a < r; ++a) {
        const int k = rows[a];
        z_rr(a, a) = diagonal_[k];
        for (int q = lp_[k]; q < lp_[k + 1]; ++q) {
          const int b = slot[li_[q]];
          if (b < 0) continue;
          z_rr(b, a) = z_rr(a, b) = values_[q];
        }
      }
      for (int a = 0; a < r; ++a) slot[rows[a]] = -1;
      m = l_ss.triangularView<Eigen::UnitLower>().solve(Eigen::MatrixXd::Identity(w, w));
      y.noalias() = l_rs * m;
      z_rs.noalias() = -z_rr * y;
      z_ss.noalias() = m.transpose() * d.segment(f, w).cwiseInverse().asDiagonal() * m;
      z_ss.noalias() -= y.transpose() * z_rs;
      for (int c = 0; c < w; ++c) {
        const int p = lp_[f + c], inside = w - c - 1;
        diagonal_[f + c] = z_ss(c, c);
        for (int a = 0; a < inside; ++a) {
          values_[p + a] = 0.5 * (z_ss(c + 1 + a, c) + z_ss(c, c + 1 + a));
        }
        for (int a = 0; a < r; ++a) values_[p + inside + a] = z_rs(a, c);
      }
    }
  }
  /// Z(i, j); false when (i, j) is not on the pattern.
  bool at(int i, int j, double* z) const {
    if (i == j) {
      *z = diagonal_[i];
      return true;
    }
    if (i < j) std::swap(i, j);
    const int* begin = li_ + lp_[j];
    const int* end = li_ + lp_[j + 1];
    const int* f = std::lower_bound(begin, end, i);
    if (f == end || *f != i) return false;
    *z = values_[static_cast<std::size_t>(f - li_)];
    return true;
  }

 private:
  const int* lp_;
  const int* li_;
  Eigen::VectorXd diagonal_;
  std::vector<double> values_;
};

}  // namespace

bool SparseCovariance::compute(const std::vector<std::pair<const double*, const double*>>& pairs,
                               ceres::Problem* problem, int threads, Method method) {
  blocks_.clear();
  message_.clear();
  stats_ = Stats();
  // Columns: the problem's free blocks in its order.
  std::vector<double*> all;
  problem->GetParameterBlocks(&all);
  ceres::Problem::EvaluateOptions evaluate;
  std::map<const double*, int> index;  // block -> position in evaluate.parameter_blocks
  std::vector<int> first, size;        // per block: first column, tangent size
  int n = 0;
  for (double* p : all) {
    if (problem->IsParameterBlockConstant(p)) continue;
    index[p] = static_cast<int>(first.size());
    evaluate.parameter_blocks.push_back(p);
    first.push_back(n);
    size.push_back(problem->ParameterBlockTangentSize(p));
    n += size.back();
  }
  for (const auto& [a, b] : pairs) {
    if (!index.count(a) || !index.count(b)) {
      message_ = "a requested block is constant or not in the problem";
      return false;
    }
  }
  if (pairs.empty()) return true;
  const std::clock_t start = std::clock();
  evaluate.num_threads = std::max(1, threads);
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(evaluate, nullptr, nullptr, nullptr, &crs)) {
    message_ = "the Jacobian could not be evaluated";
    return false;
  }
  const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor, int>> jacobian(
      crs.num_rows, crs.num_cols, static_cast<int>(crs.values.size()), crs.rows.data(),
      crs.cols.data(), crs.values.data());
  const Sparse information = Sparse(jacobian.transpose()) * jacobian;
  const std::clock_t evaluated = std::clock();
  stats_.evaluate_cpu_s = static_cast<double>(evaluated - start) / CLOCKS_PER_SEC;

  // The block graph of H.
  const int blocks = static_cast<int>(first.size());
  std::vector<int> block_of(static_cast<std::size_t>(n));
  for (int b = 0; b < blocks; ++b) {
    std::fill_n(block_of.begin() + first[b], size[b], b);
  }
  std::vector<std::vector<int>> neighbours(static_cast<std::size_t>(blocks));
  {
    std::vector<int> seen(static_cast<std::size_t>(blocks), -1);
    for (int b = 0; b < blocks; ++b) {
      for (int col = first[b]; col < first[b] + size[b]; ++col) {
        for (Sparse::InnerIterator it(information, col); it; ++it) {
          const int o = block_of[static_cast<std::size_t>(it.row())];
          if (o != b && seen[o] != b) {
            seen[o] = b;
            neighbours[b].push_back(o);
          }
        }
      }
      std::sort(neighbours[b].begin(), neighbours[b].end());
    }
  }
  auto coupled = [&](int a, int b) {
    return a == b || std::binary_search(neighbours[a].begin(), neighbours[a].end(), b);
  };

  // The dense group G.
  std::vector<bool> wanted(static_cast<std::size_t>(blocks), false);
  for (const auto& [a, b] : pairs) {
    for (const int k : {index[a], index[b]}) {
      wanted[k] = true;
    }
  }
  std::vector<bool> dense(static_cast<std::size_t>(blocks), false);
  if (method == Method::kSchur) {
    dense = wanted;
  } else {
    // A block touching many others fills its factor rows: dense anyway (the
    // threshold of approximate minimum degree's dense rows).
    const std::size_t crowded =
        static_cast<std::size_t>(std::max(16.0, 10.0 * std::sqrt(static_cast<double>(blocks))));
    for (int b = 0; b < blocks; ++b) {
      if (wanted[b] && neighbours[b].size() > crowded) dense[b] = true;
    }
    for (const auto& [a, b] : pairs) {
      if (!coupled(index[a], index[b])) dense[index[a]] = dense[index[b]] = true;
    }
  }
  stats_.method = method;

  // Order A by approximate minimum degree on its block graph, then G.
  std::vector<int> sparse_blocks, dense_blocks, place(static_cast<std::size_t>(blocks), -1);
  for (int b = 0; b < blocks; ++b) {
    if (dense[b]) {
      dense_blocks.push_back(b);
    } else {
      place[b] = static_cast<int>(sparse_blocks.size());
      sparse_blocks.push_back(b);
    }
  }
  std::vector<int> order = sparse_blocks;  // new position -> block
  if (!sparse_blocks.empty()) {
    std::vector<Eigen::Triplet<double>> graph;
    for (const int b : sparse_blocks) {
      graph.emplace_back(place[b], place[b], 1.0);
      for (const int o : neighbours[b]) {
        if (!dense[o]) graph.emplace_back(place[o], place[b], 1.0);
      }
    }
    const int m = static_cast<int>(sparse_blocks.size());
    Sparse pattern(m, m);
    pattern.setFromTriplets(graph.begin(), graph.end());
    Eigen::AMDOrdering<int> amd;
    Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation;
    amd(pattern, permutation);  // indices()[new] = old
    for (int k = 0; k < m; ++k) order[k] = sparse_blocks[permutation.indices()[k]];
  }
  order.insert(order.end(), dense_blocks.begin(), dense_blocks.end());
  std::vector<int> renumber(static_cast<std::size_t>(n));  // problem column -> new column
  std::vector<int> new_first(static_cast<std::size_t>(blocks));
  {
    int next = 0;
    for (const int b : order) {
      new_first[b] = next;
      for (int k = 0; k < size[b]; ++k) renumber[first[b] + k] = next++;
    }
  }
  int na = 0;
  for (const int b : sparse_blocks) na += size[b];
  const int ng = n - na;
  stats_.sparse_columns = na;
  stats_.dense_columns = ng;

  // H = [A B; B^T C] in the new order (A: lower triangle).
  std::vector<Eigen::Triplet<double>> a_entries, b_entries;
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(ng, ng);
  for (int col = 0; col < n; ++col) {
    const int c = renumber[col];
    for (Sparse::InnerIterator it(information, col); it; ++it) {
      const int r = renumber[static_cast<std::size_t>(it.row())];
      if (r < na && c < na) {
        if (r >= c) a_entries.emplace_back(r, c, it.value());
      } else if (r < na) {
        b_entries.emplace_back(r, c - na, it.value());
      } else if (c >= na) {
        s(r - na, c - na) = it.value();
      }
    }
  }
  // Every entry of a requested block pair in A on the pattern (explicit
  // zeros where H has none).
  for (const auto& [pa, pb] : pairs) {
    const int a = index[pa], b = index[pb];
    if (dense[a] || dense[b]) continue;
    for (int u = 0; u < size[a]; ++u) {
      for (int v = 0; v < size[b]; ++v) {
        const int r = new_first[a] + u, c = new_first[b] + v;
        a_entries.emplace_back(std::max(r, c), std::min(r, c), 0.0);
      }
    }
  }

  Eigen::SimplicialLDLT<Sparse, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt;
  if (na > 0) {
    Sparse h_aa(na, na);
    h_aa.setFromTriplets(a_entries.begin(), a_entries.end());
    a_entries = {};
    ldlt.compute(h_aa);
    if (ldlt.info() != Eigen::Success || !definite(ldlt.vectorD())) {
      message_ = kSingular;
      return false;
    }
    stats_.factor_nonzeros = ldlt.matrixL().nestedExpression().nonZeros();
  }

  // Rows of W = A^-1 B kept: the requested blocks in A.
  std::vector<int> kept_row(static_cast<std::size_t>(na), -1);
  std::vector<int> kept;
  for (const int b : sparse_blocks) {
    if (!wanted[b]) continue;
    for (int k = 0; k < size[b]; ++k) {
      kept_row[new_first[b] + k] = static_cast<int>(kept.size());
      kept.push_back(new_first[b] + k);
    }
  }
  // W and W S^-1 are dense: the requested sparse rows by the dense columns.
  const double dense_entries =
      2.0 * static_cast<double>(kept.size()) * ng + static_cast<double>(ng) * ng;
  if (dense_entries > static_cast<double>(max_dense_entries_)) {
    std::ostringstream why;
    why << "the dense part would take " << std::llround(dense_entries * 8 / (1 << 20)) << " MiB ("
        << kept.size() << " requested sparse columns x " << ng
        << " dense ones), more than the limit of "
        << std::llround(static_cast<double>(max_dense_entries_) * 8 / (1 << 20)) << " MiB";
    message_ = why.str();
    return false;
  }
  Eigen::MatrixXd cov_gg, w, w_cov;  // S^-1; W and W S^-1 (kept rows)
  if (ng > 0) {
    w.setZero(static_cast<Eigen::Index>(kept.size()), ng);
    if (na > 0) {
      Sparse h_ag(na, ng);
      h_ag.setFromTriplets(b_entries.begin(), b_entries.end());
      b_entries = {};
      // S = C - B^T (A^-1 B), by batches of columns.
      constexpr int kBatch = 64;
      for (int f = 0; f < ng; f += kBatch) {
        const int width = std::min(kBatch, ng - f);
        const Eigen::MatrixXd y = ldlt.solve(Eigen::MatrixXd(h_ag.middleCols(f, width)));
        // Row-major: each nonzero of B^T reads a contiguous row of y (1.7x
        // faster on `paper_det`, where this product is half the time) and
        // adds it to a contiguous row of the product, which the column-major
        // S would have taken with a stride (most of this function's own time
        // on `paper_det`'s final covariance, 264-280 dense columns).
        using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
        const RowMatrix y_rows = y;
        RowMatrix product(ng, width);
        product.noalias() = h_ag.transpose() * y_rows;
        s.middleCols(f, width) -= product;
        for (std::size_t k = 0; k < kept.size(); ++k) {
          w.row(static_cast<Eigen::Index>(k)).segment(f, width) = y_rows.row(kept[k]);
        }
      }
    }
    s = 0.5 * (s + s.transpose());
    const Eigen::LDLT<Eigen::MatrixXd> s_ldlt(s);
    if (s_ldlt.info() != Eigen::Success || !definite(s_ldlt.vectorD())) {
      message_ = kSingular;
      return false;
    }
    cov_gg = s_ldlt.solve(Eigen::MatrixXd::Identity(ng, ng));
    w_cov = w * cov_gg;
  }

  bool selected = false;
  for (const auto& [a, b] : pairs) selected |= !dense[index[a]] && !dense[index[b]];
  std::unique_ptr<SelectedInverse> z;
  if (selected)
    z = std::make_unique<SelectedInverse>(ldlt.matrixL().nestedExpression(), ldlt.vectorD());

  for (const auto& [pa, pb] : pairs) {
    const int a = index[pa], b = index[pb];
    Eigen::MatrixXd out(size[a], size[b]);
    for (int u = 0; u < size[a]; ++u) {
      for (int v = 0; v < size[b]; ++v) {
        const int r = new_first[a] + u, c = new_first[b] + v;
        double value = 0;
        if (r >= na && c >= na) {
          value = cov_gg(r - na, c - na);
        } else if (r >= na) {
          value = -w_cov(kept_row[c], r - na);
        } else if (c >= na) {
          value = -w_cov(kept_row[r], c - na);
        } else {
          if (!z->at(r, c, &value)) {
            message_ = "internal: a requested entry is not on the factor's pattern";
            blocks_.clear();
            return false;
          }
          if (ng > 0) value += w_cov.row(kept_row[r]).dot(w.row(kept_row[c]));
        }
        out(u, v) = value;
      }
    }
    blocks_[{pa, pb}] = out;
  }
  stats_.rest_cpu_s = static_cast<double>(std::clock() - evaluated) / CLOCKS_PER_SEC;
  return true;
}

std::string SparseCovariance::describe() const {
  std::ostringstream out;
  out << " (" << (stats_.method == Method::kSchur ? "Schur complement" : "selected inversion")
      << ": " << stats_.sparse_columns << " sparse + " << stats_.dense_columns << " dense columns, "
      << stats_.factor_nonzeros << " factor nonzeros; CPU " << stats_.evaluate_cpu_s
      << " s Jacobian and J^T J, " << stats_.rest_cpu_s << " s the rest)";
  return out.str();
}

Eigen::MatrixXd SparseCovariance::block(const double* a, const double* b) const {
  if (const auto f = blocks_.find({a, b}); f != blocks_.end()) return f->second;
  if (const auto f = blocks_.find({b, a}); f != blocks_.end()) return f->second.transpose();
  throw std::invalid_argument("SparseCovariance: block not computed");
}

}  // namespace lookboth::calib_detail
