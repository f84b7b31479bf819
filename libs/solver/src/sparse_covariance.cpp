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
  stats_.evaluate_cpu_s = static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;

  // The block graph of H = J^T J: blocks that share a row of J. The rows of
  // one residual block name the same blocks: a row like the one before adds
  // nothing.
  const int blocks = static_cast<int>(first.size());
  std::vector<int> block_of(static_cast<std::size_t>(n));
  for (int b = 0; b < blocks; ++b) {
    std::fill_n(block_of.begin() + first[b], size[b], b);
  }
  std::vector<std::vector<int>> neighbours(static_cast<std::size_t>(blocks));
  {
    std::vector<int> row_blocks, previous;
    for (int r = 0; r < crs.num_rows; ++r) {
      row_blocks.clear();
      for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) {
        row_blocks.push_back(block_of[static_cast<std::size_t>(crs.cols[k])]);
      }
      std::sort(row_blocks.begin(), row_blocks.end());
      row_blocks.erase(std::unique(row_blocks.begin(), row_blocks.end()), row_blocks.end());
      if (row_blocks == previous) continue;
      for (const int u : row_blocks) {
        for (const int v : row_blocks) {
          if (u != v) neighbours[u].push_back(v);
        }
      }
      previous = row_blocks;
    }
    for (auto& list : neighbours) {
      std::sort(list.begin(), list.end());
      list.erase(std::unique(list.begin(), list.end()), list.end());
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

  // H = [A B; B^T C] in the new order, accumulated by blocks: the rows of
  // one residual block are consecutive in J, name the same columns and make
  // a dense m x k matrix J_g (its parameter blocks' columns side by side), so
  // H gains the dense J_g^T J_g, cut into its parameter blocks' pairs and
  // added to each pair's dense block of H's lower triangle (in the new
  // order). Then A's lower triangle in compressed columns, B's entries and
  // the dense C. (Formed whole as a sparse product, J^T J took as long as
  // the rest of this function on `paper_det`.)
  const std::clock_t product_start = std::clock();
  // Per block column V: the blocks U at or after it in the new order that H
  // couples with it, sorted by position, and where their dense block
  // (size[U] x size[V], column-major) starts in `values`.
  std::vector<std::vector<std::pair<int, std::size_t>>> lower(static_cast<std::size_t>(blocks));
  std::size_t total = 0;
  for (int v = 0; v < blocks; ++v) {
    auto& list = lower[static_cast<std::size_t>(v)];
    list.emplace_back(v, 0);
    for (const int u : neighbours[v]) {
      if (new_first[u] > new_first[v]) list.emplace_back(u, 0);
    }
    std::sort(list.begin(), list.end(), [&](const auto& x, const auto& y) {
      return new_first[x.first] < new_first[y.first];
    });
    for (auto& [u, offset] : list) {
      offset = total;
      total += static_cast<std::size_t>(size[u]) * static_cast<std::size_t>(size[v]);
    }
  }
  std::vector<double> values(total, 0.0);
  auto blockAt = [&](int u, int v) -> double* {  // new_first[u] >= new_first[v]
    const auto& list = lower[static_cast<std::size_t>(v)];
    const auto it = std::lower_bound(
        list.begin(), list.end(), new_first[u],
        [&](const std::pair<int, std::size_t>& x, int at) { return new_first[x.first] < at; });
    return values.data() + it->second;
  };
  {
    struct Run {
      int block, column;  // its first column within J_g
    };
    std::vector<Run> runs;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::MatrixXd product;
    int r = 0;
    while (r < crs.num_rows) {
      const int begin = crs.rows[r], k = crs.rows[r + 1] - begin;
      int end_row = r + 1;  // the rows naming the same columns
      while (end_row < crs.num_rows && crs.rows[end_row + 1] - crs.rows[end_row] == k &&
             std::equal(crs.cols.begin() + begin, crs.cols.begin() + begin + k,
                        crs.cols.begin() + crs.rows[end_row])) {
        ++end_row;
      }
      // A parameter block's columns side by side and in order (Ceres writes
      // a residual block's Jacobian by dense cells); checked, not assumed.
      runs.clear();
      for (int q = 0; q < k;) {
        const int b = block_of[static_cast<std::size_t>(crs.cols[begin + q])];
        for (int i = 0; i < size[b]; ++i) {
          if (q + i >= k || crs.cols[begin + q + i] != first[b] + i) {
            message_ = "internal: a parameter block's Jacobian columns are not contiguous";
            return false;
          }
        }
        runs.push_back({b, q});
        q += size[b];
      }
      const Eigen::Map<const RowMajor> jg(crs.values.data() + begin, end_row - r, k);
      product.noalias() = jg.transpose() * jg;
      for (const Run& x : runs) {
        for (const Run& y : runs) {
          if (new_first[x.block] < new_first[y.block]) continue;  // x at or after y
          Eigen::Map<Eigen::MatrixXd> target(blockAt(x.block, y.block), size[x.block],
                                             size[y.block]);
          target += product.block(x.column, y.column, size[x.block], size[y.block]);
        }
      }
      r = end_row;
    }
  }
  std::vector<int> a_start(static_cast<std::size_t>(na) + 1, 0), a_rows;
  std::vector<double> a_values;
  std::vector<Eigen::Triplet<double>> b_entries;
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(ng, ng);
  for (const int v : order) {
    for (int j = 0; j < size[v]; ++j) {
      const int c = new_first[v] + j;
      for (const auto& [u, offset] : lower[static_cast<std::size_t>(v)]) {
        const double* block = values.data() + offset;  // size[u] x size[v], column-major
        for (int i = u == v ? j : 0; i < size[u]; ++i) {
          const int row = new_first[u] + i;
          const double value = block[static_cast<std::size_t>(j) * size[u] + i];
          if (c < na && row < na) {
            a_rows.push_back(row);
            a_values.push_back(value);
          } else if (c < na) {
            b_entries.emplace_back(c, row - na, value);
          } else {
            s(row - na, c - na) = value;
            s(c - na, row - na) = value;
          }
        }
      }
      if (c < na) a_start[static_cast<std::size_t>(c) + 1] = static_cast<int>(a_rows.size());
    }
  }
  stats_.evaluate_cpu_s += static_cast<double>(std::clock() - product_start) / CLOCKS_PER_SEC;

  Eigen::SimplicialLDLT<Sparse, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt;
  if (na > 0) {
    const Sparse h_aa = Eigen::Map<const Sparse>(na, na, static_cast<Eigen::Index>(a_rows.size()),
                                                 a_start.data(), a_rows.data(), a_values.data());
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
  stats_.rest_cpu_s =
      static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC - stats_.evaluate_cpu_s;
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

}  // namespace lookboth
