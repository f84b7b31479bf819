#include "lookboth/solver/fill_reducing_ordering.h"

#include <suitesparse/cholmod.h>

#include <algorithm>
#include <cstddef>
#include <limits>
#include <unordered_map>
#include <utility>

namespace lookboth {
namespace {

// One cholmod_common for the lifetime of a call.
class Cholmod {
 public:
  Cholmod() { cholmod_start(&common_); }
  ~Cholmod() { cholmod_finish(&common_); }
  Cholmod(const Cholmod&) = delete;
  Cholmod& operator=(const Cholmod&) = delete;
  cholmod_common* common() { return &common_; }

 private:
  cholmod_common common_{};
};

// The block pattern as CHOLMOD's symmetric (upper) pattern matrix.
cholmod_sparse* upperPattern(const std::vector<std::vector<int>>& columns, Cholmod& cholmod) {
  const std::size_t n = columns.size();
  std::size_t nnz = 0;
  for (const auto& c : columns) nnz += c.size();
  cholmod_sparse* a = cholmod_allocate_sparse(n, n, nnz, /*sorted=*/1, /*packed=*/1, /*stype=*/1,
                                              CHOLMOD_PATTERN, cholmod.common());
  if (a == nullptr) return nullptr;
  int* p = static_cast<int*>(a->p);
  int* i = static_cast<int*>(a->i);
  std::size_t k = 0;
  for (std::size_t j = 0; j < n; ++j) {
    p[j] = static_cast<int>(k);
    for (int row : columns[j]) i[k++] = row;
  }
  p[n] = static_cast<int>(k);
  return a;
}

void sortUnique(std::vector<int>& v) {
  std::sort(v.begin(), v.end());
  v.erase(std::unique(v.begin(), v.end()), v.end());
}

// Each block's neighbours, sorted, unique, within range, with itself, and
// symmetric (k in j's list puts j in k's). The lists come with many
// duplicates (every residual of a camera names it): deduplicated first.
std::vector<std::vector<int>> cleanAdjacency(const BlockPattern& pattern) {
  const int n = static_cast<int>(pattern.block_size.size());
  std::vector<std::vector<int>> adjacent(static_cast<std::size_t>(n));
  for (int j = 0; j < n && static_cast<std::size_t>(j) < pattern.adjacent.size(); ++j) {
    auto& a = adjacent[static_cast<std::size_t>(j)];
    for (int k : pattern.adjacent[static_cast<std::size_t>(j)]) {
      if (k >= 0 && k < n && k != j) a.push_back(k);
    }
    sortUnique(a);
  }
  std::vector<std::size_t> own(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j)
    own[static_cast<std::size_t>(j)] = adjacent[static_cast<std::size_t>(j)].size();
  for (int j = 0; j < n; ++j) {
    const auto& a = adjacent[static_cast<std::size_t>(j)];
    for (std::size_t i = 0; i < own[static_cast<std::size_t>(j)]; ++i) {
      adjacent[static_cast<std::size_t>(a[i])].push_back(j);
    }
  }
  for (int j = 0; j < n; ++j) {
    adjacent[static_cast<std::size_t>(j)].push_back(j);
    sortUnique(adjacent[static_cast<std::size_t>(j)]);
  }
  return adjacent;
}

// predictedFactorisationFlops on a clean adjacency.
double predictFlops(const std::vector<std::vector<int>>& adjacent,
                    const std::vector<int>& block_size, const std::vector<int>& order) {
  const std::size_t n = adjacent.size();
  if (order.size() != n) return std::numeric_limits<double>::quiet_NaN();
  std::vector<int> position(n, -1);
  for (std::size_t k = 0; k < n; ++k)
    position[static_cast<std::size_t>(order[k])] = static_cast<int>(k);
  // Symbolic factorisation in the permuted numbering: the structure of
  // column j below the diagonal is j's later neighbours and the structures of
  // its children in the elimination tree (the columns whose first
  // below-diagonal entry is j), without j.
  std::vector<std::vector<int>> below(n);
  std::vector<std::vector<int>> children(n);
  std::vector<int> rows;
  double flops = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const std::size_t block = static_cast<std::size_t>(order[j]);
    rows.clear();
    for (int k : adjacent[block]) {
      const int pk = position[static_cast<std::size_t>(k)];
      if (pk > static_cast<int>(j)) rows.push_back(pk);
    }
    for (int c : children[j]) {
      auto& child = below[static_cast<std::size_t>(c)];
      for (int r : child) {
        if (r != static_cast<int>(j)) rows.push_back(r);
      }
      std::vector<int>().swap(child);  // no longer needed
    }
    sortUnique(rows);
    double rows_below = 0;  // scalar rows below the block
    for (int r : rows)
      rows_below += block_size[static_cast<std::size_t>(order[static_cast<std::size_t>(r)])];
    // The block's scalar columns: column c of s has s - c + rows_below
    // entries; CHOLMOD counts a column of m entries as m^2 flops.
    const int s = block_size[block];
    for (int c = 0; c < s; ++c) {
      const double m = (s - c) + rows_below;
      flops += m * m;
    }
    if (!rows.empty())
      children[static_cast<std::size_t>(rows.front())].push_back(static_cast<int>(j));
    below[j] = rows;
  }
  return flops;
}

}  // namespace

bool parseFillOrderingMethod(const std::string& text, FillOrderingMethod* method) {
  if (text == "amd") {
    *method = FillOrderingMethod::kAmd;
  } else if (text == "nested_dissection") {
    *method = FillOrderingMethod::kNestedDissection;
  } else if (text == "auto") {
    *method = FillOrderingMethod::kAuto;
  } else {
    return false;
  }
  return true;
}

const char* fillOrderingMethodName(FillOrderingMethod method) {
  switch (method) {
    case FillOrderingMethod::kAmd:
      return "amd";
    case FillOrderingMethod::kNestedDissection:
      return "nested_dissection";
    case FillOrderingMethod::kAuto:
      break;
  }
  return "auto";
}

double predictedFactorisationFlops(const BlockPattern& pattern, const std::vector<int>& order) {
  return predictFlops(cleanAdjacency(pattern), pattern.block_size, order);
}

bool orderBlocks(const BlockPattern& pattern, FillOrderingMethod method, FillOrdering* ordering,
                 std::string* message) {
  const std::vector<std::vector<int>> adjacent = cleanAdjacency(pattern);
  const std::size_t n = adjacent.size();
  *ordering = FillOrdering{};
  if (n == 0) return true;
  std::vector<std::vector<int>> upper(n);
  for (std::size_t j = 0; j < n; ++j) {
    for (int k : adjacent[j]) {
      if (k <= static_cast<int>(j)) upper[j].push_back(k);
    }
  }
  Cholmod cholmod;
  cholmod_sparse* a = upperPattern(upper, cholmod);
  if (a == nullptr) {
    *message = "CHOLMOD could not allocate the block pattern";
    return false;
  }
  auto run = [&](FillOrderingMethod m, std::vector<int>* perm) {
    perm->assign(n, 0);
    const int ok =
        m == FillOrderingMethod::kAmd
            ? cholmod_amd(a, nullptr, 0, perm->data(), cholmod.common())
            : cholmod_metis(a, nullptr, 0, /*postorder=*/1, perm->data(), cholmod.common());
    if (!ok || cholmod.common()->status != CHOLMOD_OK) {
      *message = std::string("CHOLMOD's ") + (m == FillOrderingMethod::kAmd ? "AMD" : "METIS") +
                 " ordering failed (status " + std::to_string(cholmod.common()->status) + ")";
      return false;
    }
    return true;
  };
  bool ok = true;
  if (method == FillOrderingMethod::kAuto) {
    std::vector<int> amd, nd;
    ok = run(FillOrderingMethod::kAmd, &amd) && run(FillOrderingMethod::kNestedDissection, &nd);
    if (ok) {
      const double f_amd = predictFlops(adjacent, pattern.block_size, amd);
      const double f_nd = predictFlops(adjacent, pattern.block_size, nd);
      const bool use_nd = f_nd < kNestedDissectionMargin * f_amd;
      ordering->order = use_nd ? std::move(nd) : std::move(amd);
      ordering->method = use_nd ? FillOrderingMethod::kNestedDissection : FillOrderingMethod::kAmd;
      ordering->predicted_flops = use_nd ? f_nd : f_amd;
      ordering->predicted_flops_other = use_nd ? f_amd : f_nd;
    }
  } else {
    ok = run(method, &ordering->order);
    if (ok) {
      ordering->method = method;
      ordering->predicted_flops = predictFlops(adjacent, pattern.block_size, ordering->order);
    }
  }
  cholmod_free_sparse(&a, cholmod.common());
  return ok;
}

std::shared_ptr<ceres::ParameterBlockOrdering> solverOrdering(const ceres::Problem& problem,
                                                              FillOrderingMethod method,
                                                              FillOrdering* chosen,
                                                              std::string* message) {
  std::vector<double*> blocks;
  problem.GetParameterBlocks(&blocks);
  std::unordered_map<const double*, int> index;  // free blocks -> pattern index
  BlockPattern pattern;
  std::vector<double*> free_blocks;
  for (double* b : blocks) {
    if (problem.IsParameterBlockConstant(b)) continue;
    index.emplace(b, static_cast<int>(free_blocks.size()));
    free_blocks.push_back(b);
    pattern.block_size.push_back(problem.ParameterBlockTangentSize(b));
  }
  pattern.adjacent.resize(free_blocks.size());
  std::vector<ceres::ResidualBlockId> residuals;
  problem.GetResidualBlocks(&residuals);
  std::vector<double*> touched;
  std::vector<int> ids;
  for (const ceres::ResidualBlockId id : residuals) {
    problem.GetParameterBlocksForResidualBlock(id, &touched);
    ids.clear();
    for (double* b : touched) {
      const auto it = index.find(b);
      if (it != index.end()) ids.push_back(it->second);
    }
    for (int i : ids) {
      for (int j : ids) {
        if (j > i) pattern.adjacent[static_cast<std::size_t>(i)].push_back(j);
      }
    }
  }
  FillOrdering ordering;
  message->clear();
  if (!orderBlocks(pattern, method, &ordering, message)) return nullptr;
  if (chosen != nullptr) *chosen = ordering;
  if (ordering.method == FillOrderingMethod::kAmd) return nullptr;  // Ceres' own AMD
  auto groups = std::make_shared<ceres::ParameterBlockOrdering>();
  int group = 0;
  for (int k : ordering.order) {
    groups->AddElementToGroup(free_blocks[static_cast<std::size_t>(k)], group++);
  }
  for (double* b : blocks) {
    if (index.count(b) == 0) groups->AddElementToGroup(b, group++);
  }
  return groups;
}

}  // namespace lookboth
