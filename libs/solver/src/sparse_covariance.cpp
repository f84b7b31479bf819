#include "lookboth/solver/sparse_covariance.h"

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

namespace lookboth {
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

using BlockPairs = std::vector<std::pair<const double*, const double*>>;

// SparseCovariance::compute's steps over one problem, in the order run()
// calls them; the members are what the steps hand each other.
class CovarianceComputation {
 public:
  CovarianceComputation(ceres::Problem* problem, SparseCovariance::Stats& stats,
                        std::string& message)
      : problem_(problem), stats_(stats), message_(message) {}

  /// H^-1's whole columns of these blocks too (SparseCovariance::requestWholeColumns).
  void requestWholeColumns(const std::vector<const double*>& blocks) { whole_request_ = blocks; }
  /// The whole columns, and where each free block's rows start in them.
  Eigen::MatrixXd wholeColumns(std::map<const double*, int>* row_of_block) const {
    if (whole_columns_.size() == 0) return {};
    for (const auto& [block, b] : index_) (*row_of_block)[block] = new_first_[b];
    return whole_columns_;
  }

  bool run(const BlockPairs& pairs, int threads, SparseCovariance::Method method,
           std::size_t max_dense_entries,
           std::map<std::pair<const double*, const double*>, Eigen::MatrixXd>& blocks) {
    if (!collectColumns(pairs)) return false;
    if (pairs.empty()) return true;
    start_ = std::clock();
    if (!evaluateJacobian(threads)) return false;
    buildBlockGraph();
    chooseDenseGroup(pairs, method);
    orderColumns();
    const std::clock_t product_start = std::clock();
    indexLowerBlocks();
    if (!accumulateNormalEquations()) return false;
    splitNormalEquations();
    stats_.evaluate_cpu_s += static_cast<double>(std::clock() - product_start) / CLOCKS_PER_SEC;
    if (!factorSparsePart()) return false;
    keepRequestedRows();
    if (!denseSizeWithin(max_dense_entries)) return false;
    max_dense_entries_ = max_dense_entries;
    if (!invertDenseGroup()) return false;
    if (!assemble(pairs, blocks)) return false;
    keepWholeColumns();
    stats_.rest_cpu_s =
        static_cast<double>(std::clock() - start_) / CLOCKS_PER_SEC - stats_.evaluate_cpu_s;
    return true;
  }

 private:
  /// Columns: the problem's free blocks in its order. False when a requested
  /// block is not among them.
  bool collectColumns(const BlockPairs& pairs) {
    std::vector<double*> all;
    problem_->GetParameterBlocks(&all);
    for (double* p : all) {
      if (problem_->IsParameterBlockConstant(p)) continue;
      index_[p] = static_cast<int>(first_.size());
      evaluate_.parameter_blocks.push_back(p);
      first_.push_back(n_);
      size_.push_back(problem_->ParameterBlockTangentSize(p));
      n_ += size_.back();
    }
    for (const auto& [a, b] : pairs) {
      if (!index_.count(a) || !index_.count(b)) {
        message_ = "a requested block is constant or not in the problem";
        return false;
      }
    }
    return true;
  }

  bool evaluateJacobian(int threads) {
    evaluate_.num_threads = std::max(1, threads);
    if (!problem_->Evaluate(evaluate_, nullptr, nullptr, nullptr, &crs_)) {
      message_ = "the Jacobian could not be evaluated";
      return false;
    }
    stats_.evaluate_cpu_s = static_cast<double>(std::clock() - start_) / CLOCKS_PER_SEC;
    return true;
  }

  /// The block graph of H = J^T J: blocks that share a row of J. The rows of
  /// one residual block name the same blocks: a row like the one before adds
  /// nothing.
  void buildBlockGraph() {
    blocks_ = static_cast<int>(first_.size());
    block_of_.assign(static_cast<std::size_t>(n_), 0);
    for (int b = 0; b < blocks_; ++b) {
      std::fill_n(block_of_.begin() + first_[b], size_[b], b);
    }
    neighbours_.assign(static_cast<std::size_t>(blocks_), {});
    std::vector<int> row_blocks, previous;
    for (int r = 0; r < crs_.num_rows; ++r) {
      row_blocks.clear();
      for (int k = crs_.rows[r]; k < crs_.rows[r + 1]; ++k) {
        row_blocks.push_back(block_of_[static_cast<std::size_t>(crs_.cols[k])]);
      }
      std::sort(row_blocks.begin(), row_blocks.end());
      row_blocks.erase(std::unique(row_blocks.begin(), row_blocks.end()), row_blocks.end());
      if (row_blocks == previous) continue;
      for (const int u : row_blocks) {
        for (const int v : row_blocks) {
          if (u != v) neighbours_[u].push_back(v);
        }
      }
      previous = row_blocks;
    }
    for (auto& list : neighbours_) {
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
    }
  }

  bool coupled(int a, int b) const {
    return a == b || std::binary_search(neighbours_[a].begin(), neighbours_[a].end(), b);
  }

  /// The dense group G: every requested block with kSchur; else the
  /// requested blocks touching many others, and both blocks of every
  /// requested pair H does not couple.
  void chooseDenseGroup(const BlockPairs& pairs, SparseCovariance::Method method) {
    wanted_.assign(static_cast<std::size_t>(blocks_), false);
    for (const auto& [a, b] : pairs) {
      for (const int k : {index_[a], index_[b]}) wanted_[k] = true;
    }
    dense_.assign(static_cast<std::size_t>(blocks_), false);
    if (method == SparseCovariance::Method::kSchur) {
      dense_ = wanted_;
    } else {
      // A block touching many others fills its factor rows: dense anyway (the
      // threshold of approximate minimum degree's dense rows).
      const std::size_t crowded =
          static_cast<std::size_t>(std::max(16.0, 10.0 * std::sqrt(static_cast<double>(blocks_))));
      for (int b = 0; b < blocks_; ++b) {
        if (wanted_[b] && neighbours_[b].size() > crowded) dense_[b] = true;
      }
      for (const auto& [a, b] : pairs) {
        if (!coupled(index_[a], index_[b])) dense_[index_[a]] = dense_[index_[b]] = true;
      }
    }
    stats_.method = method;
  }

  /// A's blocks by approximate minimum degree on its block graph, then G's.
  void orderColumns() {
    std::vector<int> place(static_cast<std::size_t>(blocks_), -1);
    for (int b = 0; b < blocks_; ++b) {
      if (dense_[b]) {
        dense_blocks_.push_back(b);
      } else {
        place[b] = static_cast<int>(sparse_blocks_.size());
        sparse_blocks_.push_back(b);
      }
    }
    order_ = sparse_blocks_;  // new position -> block
    if (!sparse_blocks_.empty()) {
      std::vector<Eigen::Triplet<double>> graph;
      for (const int b : sparse_blocks_) {
        graph.emplace_back(place[b], place[b], 1.0);
        for (const int o : neighbours_[b]) {
          if (!dense_[o]) graph.emplace_back(place[o], place[b], 1.0);
        }
      }
      const int m = static_cast<int>(sparse_blocks_.size());
      Sparse pattern(m, m);
      pattern.setFromTriplets(graph.begin(), graph.end());
      Eigen::AMDOrdering<int> amd;
      Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation;
      amd(pattern, permutation);  // indices()[new] = old
      for (int k = 0; k < m; ++k) order_[k] = sparse_blocks_[permutation.indices()[k]];
    }
    order_.insert(order_.end(), dense_blocks_.begin(), dense_blocks_.end());
    new_first_.assign(static_cast<std::size_t>(blocks_), 0);
    int next = 0;
    for (const int b : order_) {
      new_first_[b] = next;
      next += size_[b];
    }
    na_ = 0;
    for (const int b : sparse_blocks_) na_ += size_[b];
    ng_ = n_ - na_;
    stats_.sparse_columns = na_;
    stats_.dense_columns = ng_;
  }

  /// Per block column V: the blocks U at or after it in the new order that H
  /// couples with it, sorted by position, and where their dense block
  /// (size[U] x size[V], column-major) starts in values_.
  void indexLowerBlocks() {
    lower_.assign(static_cast<std::size_t>(blocks_), {});
    std::size_t total = 0;
    for (int v = 0; v < blocks_; ++v) {
      auto& list = lower_[static_cast<std::size_t>(v)];
      list.emplace_back(v, 0);
      for (const int u : neighbours_[v]) {
        if (new_first_[u] > new_first_[v]) list.emplace_back(u, 0);
      }
      std::sort(list.begin(), list.end(), [&](const auto& x, const auto& y) {
        return new_first_[x.first] < new_first_[y.first];
      });
      for (auto& [u, offset] : list) {
        offset = total;
        total += static_cast<std::size_t>(size_[u]) * static_cast<std::size_t>(size_[v]);
      }
    }
    values_.assign(total, 0.0);
  }

  double* blockAt(int u, int v) {  // new_first_[u] >= new_first_[v]
    const auto& list = lower_[static_cast<std::size_t>(v)];
    const auto it = std::lower_bound(
        list.begin(), list.end(), new_first_[u],
        [&](const std::pair<int, std::size_t>& x, int at) { return new_first_[x.first] < at; });
    return values_.data() + it->second;
  }

  /// H in the new order, accumulated by blocks: the rows of one residual
  /// block are consecutive in J, name the same columns and make a dense
  /// m x k matrix J_g (its parameter blocks' columns side by side), so H
  /// gains the dense J_g^T J_g, cut into its parameter blocks' pairs and
  /// added to each pair's dense block of H's lower triangle. (Formed whole
  /// as a sparse product, J^T J took as long as the rest of compute() on
  /// `paper_det`.)
  bool accumulateNormalEquations() {
    struct Run {
      int block, column;  // its first column within J_g
    };
    std::vector<Run> runs;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::MatrixXd product;
    int r = 0;
    while (r < crs_.num_rows) {
      const int begin = crs_.rows[r], k = crs_.rows[r + 1] - begin;
      int end_row = r + 1;  // the rows naming the same columns
      while (end_row < crs_.num_rows && crs_.rows[end_row + 1] - crs_.rows[end_row] == k &&
             std::equal(crs_.cols.begin() + begin, crs_.cols.begin() + begin + k,
                        crs_.cols.begin() + crs_.rows[end_row])) {
        ++end_row;
      }
      // A parameter block's columns side by side and in order (Ceres writes
      // a residual block's Jacobian by dense cells); checked, not assumed.
      runs.clear();
      for (int q = 0; q < k;) {
        const int b = block_of_[static_cast<std::size_t>(crs_.cols[begin + q])];
        for (int i = 0; i < size_[b]; ++i) {
          if (q + i >= k || crs_.cols[begin + q + i] != first_[b] + i) {
            message_ = "internal: a parameter block's Jacobian columns are not contiguous";
            return false;
          }
        }
        runs.push_back({b, q});
        q += size_[b];
      }
      const Eigen::Map<const RowMajor> jg(crs_.values.data() + begin, end_row - r, k);
      product.noalias() = jg.transpose() * jg;
      for (const Run& x : runs) {
        for (const Run& y : runs) {
          if (new_first_[x.block] < new_first_[y.block]) continue;  // x at or after y
          Eigen::Map<Eigen::MatrixXd> target(blockAt(x.block, y.block), size_[x.block],
                                             size_[y.block]);
          target += product.block(x.column, y.column, size_[x.block], size_[y.block]);
        }
      }
      r = end_row;
    }
    return true;
  }

  /// H = [A B; B^T C]: A's lower triangle in compressed columns, B's
  /// entries and the dense C (in s_, which the Schur complement updates).
  void splitNormalEquations() {
    a_start_.assign(static_cast<std::size_t>(na_) + 1, 0);
    s_ = Eigen::MatrixXd::Zero(ng_, ng_);
    for (const int v : order_) {
      for (int j = 0; j < size_[v]; ++j) {
        const int c = new_first_[v] + j;
        for (const auto& [u, offset] : lower_[static_cast<std::size_t>(v)]) {
          const double* block = values_.data() + offset;  // size[u] x size[v], column-major
          for (int i = u == v ? j : 0; i < size_[u]; ++i) {
            const int row = new_first_[u] + i;
            const double value = block[static_cast<std::size_t>(j) * size_[u] + i];
            if (c < na_ && row < na_) {
              a_rows_.push_back(row);
              a_values_.push_back(value);
            } else if (c < na_) {
              b_entries_.emplace_back(c, row - na_, value);
            } else {
              s_(row - na_, c - na_) = value;
              s_(c - na_, row - na_) = value;
            }
          }
        }
        if (c < na_) a_start_[static_cast<std::size_t>(c) + 1] = static_cast<int>(a_rows_.size());
      }
    }
  }

  /// A = L D L^T (the columns already in their elimination order).
  bool factorSparsePart() {
    if (na_ == 0) return true;
    const Sparse h_aa =
        Eigen::Map<const Sparse>(na_, na_, static_cast<Eigen::Index>(a_rows_.size()),
                                 a_start_.data(), a_rows_.data(), a_values_.data());
    ldlt_.compute(h_aa);
    if (ldlt_.info() != Eigen::Success || !definite(ldlt_.vectorD())) {
      message_ = kSingular;
      return false;
    }
    stats_.factor_nonzeros = ldlt_.matrixL().nestedExpression().nonZeros();
    return true;
  }

  /// Rows of W = A^-1 B kept: the requested blocks in A.
  void keepRequestedRows() {
    kept_row_.assign(static_cast<std::size_t>(na_), -1);
    for (const int b : sparse_blocks_) {
      if (!wanted_[b]) continue;
      for (int k = 0; k < size_[b]; ++k) {
        kept_row_[new_first_[b] + k] = static_cast<int>(kept_.size());
        kept_.push_back(new_first_[b] + k);
      }
    }
  }

  /// W and W S^-1 are dense: the requested sparse rows by the dense columns.
  bool denseSizeWithin(std::size_t max_dense_entries) {
    const double dense_entries =
        2.0 * static_cast<double>(kept_.size()) * ng_ + static_cast<double>(ng_) * ng_;
    if (dense_entries <= static_cast<double>(max_dense_entries)) return true;
    std::ostringstream why;
    why << "the dense part would take " << std::llround(dense_entries * 8 / (1 << 20)) << " MiB ("
        << kept_.size() << " requested sparse columns x " << ng_
        << " dense ones), more than the limit of "
        << std::llround(static_cast<double>(max_dense_entries) * 8 / (1 << 20)) << " MiB";
    message_ = why.str();
    return false;
  }

  /// S = C - B^T (A^-1 B) by batches of columns, keeping W's requested rows.
  void schurComplement() {
    Sparse h_ag(na_, ng_);
    h_ag.setFromTriplets(b_entries_.begin(), b_entries_.end());
    b_entries_ = {};
    constexpr int kBatch = 64;
    for (int f = 0; f < ng_; f += kBatch) {
      const int width = std::min(kBatch, ng_ - f);
      const Eigen::MatrixXd y = ldlt_.solve(Eigen::MatrixXd(h_ag.middleCols(f, width)));
      // Row-major: each nonzero of B^T reads a contiguous row of y (1.7x
      // faster on `paper_det`, where this product is half the time) and
      // adds it to a contiguous row of the product, which the column-major
      // S would have taken with a stride (most of compute()'s own time on
      // `paper_det`'s final covariance, 264-280 dense columns).
      using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
      const RowMatrix y_rows = y;
      RowMatrix product(ng_, width);
      product.noalias() = h_ag.transpose() * y_rows;
      s_.middleCols(f, width) -= product;
      for (std::size_t k = 0; k < kept_.size(); ++k) {
        w_.row(static_cast<Eigen::Index>(k)).segment(f, width) = y_rows.row(kept_[k]);
      }
      if (whole_kept_) w_all_.middleCols(f, width) = y_rows;
    }
  }

  /// H^-1's whole columns of the requested dense blocks: S^-1's rows for
  /// the dense group, -A^-1 B S^-1's for the sparse part (all of W's rows).
  void keepWholeColumns() {
    if (whole_request_.empty() || !whole_kept_) return;
    std::vector<int> columns;
    for (const double* p : whole_request_) {
      const auto found = index_.find(p);
      if (found == index_.end() || !dense_[found->second]) return;  // not kept
      for (int k = 0; k < size_[found->second]; ++k)
        columns.push_back(new_first_[found->second] - na_ + k);
    }
    Eigen::MatrixXd g(ng_, static_cast<Eigen::Index>(columns.size()));
    for (std::size_t k = 0; k < columns.size(); ++k)
      g.col(static_cast<Eigen::Index>(k)) = cov_gg_.col(columns[k]);
    whole_columns_.resize(n_, g.cols());
    if (na_ > 0) whole_columns_.topRows(na_).noalias() = -w_all_ * g;
    whole_columns_.bottomRows(ng_) = g;
    w_all_.resize(0, 0);
  }

  /// cov_GG = S^-1 and W S^-1.
  bool invertDenseGroup() {
    if (ng_ == 0) return true;
    w_.setZero(static_cast<Eigen::Index>(kept_.size()), ng_);
    // W's every row, then the whole columns themselves: both within the limit.
    double columns = 0;
    for (const double* p : whole_request_) {
      if (const auto found = index_.find(p); found != index_.end()) columns += size_[found->second];
    }
    whole_kept_ = !whole_request_.empty() && static_cast<double>(na_) * ng_ + n_ * columns <=
                                                 static_cast<double>(max_dense_entries_);
    if (whole_kept_) w_all_.resize(na_, ng_);
    if (na_ > 0) schurComplement();
    s_ = 0.5 * (s_ + s_.transpose());
    const Eigen::LDLT<Eigen::MatrixXd> s_ldlt(s_);
    if (s_ldlt.info() != Eigen::Success || !definite(s_ldlt.vectorD())) {
      message_ = kSingular;
      return false;
    }
    cov_gg_ = s_ldlt.solve(Eigen::MatrixXd::Identity(ng_, ng_));
    w_cov_ = w_ * cov_gg_;
    return true;
  }

  /// Each requested pair's block from cov_GG, -W S^-1 and the selected
  /// inverse of A plus W S^-1 W^T.
  bool assemble(const BlockPairs& pairs,
                std::map<std::pair<const double*, const double*>, Eigen::MatrixXd>& blocks) {
    bool selected = false;
    for (const auto& [a, b] : pairs) selected |= !dense_[index_[a]] && !dense_[index_[b]];
    std::unique_ptr<SelectedInverse> z;
    if (selected)
      z = std::make_unique<SelectedInverse>(ldlt_.matrixL().nestedExpression(), ldlt_.vectorD());
    for (const auto& [pa, pb] : pairs) {
      const int a = index_[pa], b = index_[pb];
      Eigen::MatrixXd out(size_[a], size_[b]);
      for (int u = 0; u < size_[a]; ++u) {
        for (int v = 0; v < size_[b]; ++v) {
          const int r = new_first_[a] + u, c = new_first_[b] + v;
          double value = 0;
          if (r >= na_ && c >= na_) {
            value = cov_gg_(r - na_, c - na_);
          } else if (r >= na_) {
            value = -w_cov_(kept_row_[c], r - na_);
          } else if (c >= na_) {
            value = -w_cov_(kept_row_[r], c - na_);
          } else {
            if (!z->at(r, c, &value)) {
              message_ = "internal: a requested entry is not on the factor's pattern";
              blocks.clear();
              return false;
            }
            if (ng_ > 0) value += w_cov_.row(kept_row_[r]).dot(w_.row(kept_row_[c]));
          }
          out(u, v) = value;
        }
      }
      blocks[{pa, pb}] = out;
    }
    return true;
  }

  ceres::Problem* problem_;
  SparseCovariance::Stats& stats_;
  std::string& message_;
  std::clock_t start_ = 0;
  // Columns: per free block its position, first column and tangent size.
  ceres::Problem::EvaluateOptions evaluate_;
  std::map<const double*, int> index_;  // block -> position in evaluate_.parameter_blocks
  std::vector<int> first_, size_;
  int n_ = 0;
  ceres::CRSMatrix crs_;
  // The block graph.
  int blocks_ = 0;
  std::vector<int> block_of_;
  std::vector<std::vector<int>> neighbours_;
  // The split and the order.
  std::vector<bool> wanted_, dense_;
  std::vector<int> sparse_blocks_, dense_blocks_, order_, new_first_;
  int na_ = 0, ng_ = 0;
  // H's lower triangle by blocks, then as A, B and C.
  std::vector<std::vector<std::pair<int, std::size_t>>> lower_;
  std::vector<double> values_;
  std::vector<int> a_start_, a_rows_;
  std::vector<double> a_values_;
  std::vector<Eigen::Triplet<double>> b_entries_;
  Eigen::MatrixXd s_;
  // The factor and the inverses.
  Eigen::SimplicialLDLT<Sparse, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt_;
  std::vector<int> kept_row_, kept_;
  Eigen::MatrixXd cov_gg_, w_, w_cov_;  // S^-1; W and W S^-1 (kept rows)
  // H^-1's whole columns (requestWholeColumns): W's every row while they are built.
  std::vector<const double*> whole_request_;
  bool whole_kept_ = false;
  std::size_t max_dense_entries_ = 0;
  Eigen::MatrixXd w_all_, whole_columns_;
};

}  // namespace

bool SparseCovariance::compute(const BlockPairs& pairs, ceres::Problem* problem, int threads,
                               Method method) {
  blocks_.clear();
  message_.clear();
  stats_ = Stats();
  whole_columns_.resize(0, 0);
  whole_row_.clear();
  CovarianceComputation computation(problem, stats_, message_);
  computation.requestWholeColumns(whole_request_);
  if (!computation.run(pairs, threads, method, max_dense_entries_, blocks_)) return false;
  whole_columns_ = computation.wholeColumns(&whole_row_);
  return true;
}

int SparseCovariance::wholeRow(const double* block) const {
  const auto found = whole_row_.find(block);
  return found == whole_row_.end() ? -1 : found->second;
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

}  // namespace lookboth
