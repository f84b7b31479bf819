// The fill-reducing ordering of J^T J: permutations, the flop prediction
// against CHOLMOD's own symbolic count, nested dissection on the joint
// stage's shape (a chain with hubs), and Ceres solving the same with it.
#include "lookboth/solver/fill_reducing_ordering.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>
#include <suitesparse/cholmod.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numeric>
#include <random>
#include <vector>

namespace lookboth {
namespace {

void connect(BlockPattern& p, int a, int b) {
  p.adjacent[static_cast<std::size_t>(a)].push_back(b);
}

// A trajectory-like chain of `nodes` 6-blocks, one 1-block (a scale) per 10
// nodes tied to the nodes of its segment, and `hubs` 6-blocks (cameras), each
// tied to the nodes of `passes` windows of 8 nodes spread along the chain.
BlockPattern chainWithHubs(int nodes, int hubs, int passes, unsigned seed) {
  constexpr int window = 8;
  std::mt19937 rng(seed);
  BlockPattern p;
  const int segments = (nodes + 9) / 10;
  p.block_size.assign(static_cast<std::size_t>(nodes), 6);
  p.block_size.insert(p.block_size.end(), static_cast<std::size_t>(segments), 1);
  p.block_size.insert(p.block_size.end(), static_cast<std::size_t>(hubs), 6);
  p.adjacent.resize(p.block_size.size());
  for (int k = 0; k + 1 < nodes; ++k) {
    connect(p, k, k + 1);
    connect(p, k, nodes + k / 10);
    connect(p, k + 1, nodes + k / 10);
  }
  std::uniform_int_distribution<int> start(0, nodes - window);
  for (int h = 0; h < hubs; ++h) {
    const int hub = nodes + segments + h;
    for (int pass = 0; pass < passes; ++pass) {
      const int s = start(rng);
      for (int k = s; k < s + window; ++k) connect(p, hub, k);
    }
  }
  return p;
}

// A robot's trajectory over a g x g grid of cameras 1 m apart: lanes along
// every row of cameras, then along every column (a lawnmower both ways), a
// node every `step` metres, each camera tied to the nodes within `radius` of
// it (what it and the fisheye see), a scale per 10 nodes.
BlockPattern lawnmower(int g, double step, double radius) {
  std::vector<std::array<double, 2>> path;
  for (int pass = 0; pass < 2; ++pass) {
    for (int lane = 0; lane < g; ++lane) {
      const bool back = lane % 2 == 1;
      for (double u = 0; u <= g - 1 + 1e-9; u += step) {
        const double along = back ? g - 1 - u : u;
        path.push_back(pass == 0 ? std::array<double, 2>{along, double(lane)}
                                 : std::array<double, 2>{double(lane), along});
      }
    }
  }
  const int nodes = static_cast<int>(path.size());
  const int segments = (nodes + 9) / 10;
  BlockPattern p;
  p.block_size.assign(static_cast<std::size_t>(nodes), 6);
  p.block_size.insert(p.block_size.end(), static_cast<std::size_t>(segments), 1);
  p.block_size.insert(p.block_size.end(), static_cast<std::size_t>(g * g), 6);
  p.adjacent.resize(p.block_size.size());
  for (int k = 0; k + 1 < nodes; ++k) {
    connect(p, k, k + 1);
    connect(p, k, nodes + k / 10);
    connect(p, k + 1, nodes + k / 10);
  }
  for (int c = 0; c < g * g; ++c) {
    const double cx = c % g, cy = c / g;
    for (int k = 0; k < nodes; ++k) {
      if (std::hypot(path[k][0] - cx, path[k][1] - cy) <= radius)
        connect(p, nodes + segments + c, k);
    }
  }
  return p;
}

BlockPattern randomPattern(int blocks, int edges, unsigned seed) {
  std::mt19937 rng(seed);
  BlockPattern p;
  std::uniform_int_distribution<int> size(1, 6), block(0, blocks - 1);
  for (int i = 0; i < blocks; ++i) p.block_size.push_back(size(rng));
  p.adjacent.resize(static_cast<std::size_t>(blocks));
  for (int e = 0; e < edges; ++e) {
    const int to = block(rng);
    connect(p, block(rng), to);
  }
  return p;
}

bool isPermutation(std::vector<int> order, std::size_t n) {
  if (order.size() != n) return false;
  std::sort(order.begin(), order.end());
  for (std::size_t i = 0; i < n; ++i) {
    if (order[i] != static_cast<int>(i)) return false;
  }
  return true;
}

// CHOLMOD's flop count of the scalar matrix with the pattern's blocks in
// `order` (simplicial symbolic factorisation, no further ordering): what the
// prediction must equal.
double cholmodFlops(const BlockPattern& p, const std::vector<int>& order) {
  const std::size_t nb = p.block_size.size();
  std::vector<int> first(nb);  // first scalar column of each block in the permuted numbering
  int n = 0;
  for (int b : order) {
    first[static_cast<std::size_t>(b)] = n;
    n += p.block_size[static_cast<std::size_t>(b)];
  }
  std::vector<std::vector<int>> columns(static_cast<std::size_t>(n));
  auto add = [&](int a, int b) {
    for (int i = 0; i < p.block_size[static_cast<std::size_t>(a)]; ++i) {
      for (int j = 0; j < p.block_size[static_cast<std::size_t>(b)]; ++j) {
        const int r = first[static_cast<std::size_t>(a)] + i;
        const int c = first[static_cast<std::size_t>(b)] + j;
        columns[static_cast<std::size_t>(std::max(r, c))].push_back(std::min(r, c));
      }
    }
  };
  for (std::size_t a = 0; a < nb; ++a) {
    add(static_cast<int>(a), static_cast<int>(a));
    for (int b : p.adjacent[a]) add(static_cast<int>(a), b);
  }
  cholmod_common cc;
  cholmod_start(&cc);
  std::size_t nnz = 0;
  for (auto& c : columns) {
    std::sort(c.begin(), c.end());
    c.erase(std::unique(c.begin(), c.end()), c.end());
    nnz += c.size();
  }
  cholmod_sparse* a = cholmod_allocate_sparse(
      static_cast<std::size_t>(n), static_cast<std::size_t>(n), nnz, 1, 1, 1, CHOLMOD_PATTERN, &cc);
  int* ap = static_cast<int*>(a->p);
  int* ai = static_cast<int*>(a->i);
  std::size_t k = 0;
  for (int j = 0; j < n; ++j) {
    ap[j] = static_cast<int>(k);
    for (int i : columns[static_cast<std::size_t>(j)]) ai[k++] = i;
  }
  ap[n] = static_cast<int>(k);
  cc.nmethods = 1;
  cc.method[0].ordering = CHOLMOD_NATURAL;
  cc.postorder = 0;
  cc.supernodal = CHOLMOD_SIMPLICIAL;
  cholmod_factor* l = cholmod_analyze(a, &cc);
  EXPECT_NE(l, nullptr);
  const double flops = cc.fl;
  cholmod_free_factor(&l, &cc);
  cholmod_free_sparse(&a, &cc);
  cholmod_finish(&cc);
  return flops;
}

TEST(FillReducingOrdering, ParsesItsNames) {
  for (const auto m : {FillOrderingMethod::kAmd, FillOrderingMethod::kNestedDissection,
                       FillOrderingMethod::kAuto}) {
    FillOrderingMethod parsed = FillOrderingMethod::kAmd;
    EXPECT_TRUE(parseFillOrderingMethod(fillOrderingMethodName(m), &parsed));
    EXPECT_EQ(parsed, m);
  }
  FillOrderingMethod parsed = FillOrderingMethod::kAmd;
  EXPECT_FALSE(parseFillOrderingMethod("metis", &parsed));
}

TEST(FillReducingOrdering, EveryMethodGivesAPermutation) {
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const BlockPattern p = randomPattern(200, 600, seed);
    for (const auto m : {FillOrderingMethod::kAmd, FillOrderingMethod::kNestedDissection,
                         FillOrderingMethod::kAuto}) {
      FillOrdering o;
      std::string message;
      ASSERT_TRUE(orderBlocks(p, m, &o, &message)) << message;
      EXPECT_TRUE(isPermutation(o.order, p.block_size.size()));
      EXPECT_NE(o.method, FillOrderingMethod::kAuto);
      EXPECT_GT(o.predicted_flops, 0);
    }
  }
  FillOrdering empty;
  std::string message;
  EXPECT_TRUE(orderBlocks(BlockPattern{}, FillOrderingMethod::kAuto, &empty, &message));
  EXPECT_TRUE(empty.order.empty());
}

TEST(FillReducingOrdering, PredictionEqualsCholmodsCount) {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const BlockPattern p =
        seed % 2 ? randomPattern(120, 300, seed) : chainWithHubs(150, 12, 3, seed);
    std::vector<int> order(p.block_size.size());
    std::iota(order.begin(), order.end(), 0);
    std::shuffle(order.begin(), order.end(), std::mt19937(seed));
    EXPECT_EQ(predictedFactorisationFlops(p, order), cholmodFlops(p, order)) << "seed " << seed;
    FillOrdering o;
    std::string message;
    ASSERT_TRUE(orderBlocks(p, FillOrderingMethod::kNestedDissection, &o, &message)) << message;
    EXPECT_EQ(o.predicted_flops, cholmodFlops(p, o.order)) << "seed " << seed;
  }
}

// The joint stage's shape, a lawnmower under 36 cameras each seen from 2.5
// spacings away: nested dissection needs far fewer flops than AMD (0.54x),
// and kAuto takes it.
TEST(FillReducingOrdering, NestedDissectionWinsUnderAGridOfCameras) {
  const BlockPattern p = lawnmower(6, 0.05, 2.5);
  FillOrdering amd, nd, chosen;
  std::string message;
  ASSERT_TRUE(orderBlocks(p, FillOrderingMethod::kAmd, &amd, &message)) << message;
  ASSERT_TRUE(orderBlocks(p, FillOrderingMethod::kNestedDissection, &nd, &message)) << message;
  ASSERT_TRUE(orderBlocks(p, FillOrderingMethod::kAuto, &chosen, &message)) << message;
  EXPECT_LT(cholmodFlops(p, nd.order), 0.7 * cholmodFlops(p, amd.order));
  EXPECT_EQ(chosen.method, FillOrderingMethod::kNestedDissection);
  EXPECT_EQ(chosen.order, nd.order);
  EXPECT_EQ(chosen.predicted_flops, nd.predicted_flops);
  EXPECT_EQ(chosen.predicted_flops_other, amd.predicted_flops);
}

// kAuto takes nested dissection when it predicts clearly fewer flops
// (kNestedDissectionMargin), else AMD.
TEST(FillReducingOrdering, AutoTakesNestedDissectionOnClearlyFewerFlops) {
  int amd_chosen = 0, nd_chosen = 0;
  for (unsigned seed = 1; seed <= 12; ++seed) {
    const BlockPattern p = seed == 12 ? lawnmower(6, 0.05, 2.5)
                           : seed % 3
                               ? randomPattern(150, 150 + 40 * static_cast<int>(seed), seed)
                               : chainWithHubs(300, 10, 1 + static_cast<int>(seed) / 3, seed);
    FillOrdering amd, nd, chosen;
    std::string message;
    ASSERT_TRUE(orderBlocks(p, FillOrderingMethod::kAmd, &amd, &message)) << message;
    ASSERT_TRUE(orderBlocks(p, FillOrderingMethod::kNestedDissection, &nd, &message)) << message;
    ASSERT_TRUE(orderBlocks(p, FillOrderingMethod::kAuto, &chosen, &message)) << message;
    const bool nd_wins = nd.predicted_flops < kNestedDissectionMargin * amd.predicted_flops;
    EXPECT_EQ(chosen.method,
              nd_wins ? FillOrderingMethod::kNestedDissection : FillOrderingMethod::kAmd);
    EXPECT_EQ(chosen.predicted_flops, nd_wins ? nd.predicted_flops : amd.predicted_flops);
    EXPECT_EQ(chosen.predicted_flops_other, nd_wins ? amd.predicted_flops : nd.predicted_flops);
    EXPECT_EQ(chosen.order, nd_wins ? nd.order : amd.order);
    (chosen.method == FillOrderingMethod::kAmd ? amd_chosen : nd_chosen)++;
  }
  // Both branches are exercised by these patterns.
  EXPECT_GT(amd_chosen, 0);
  EXPECT_GT(nd_chosen, 0);
}

struct Difference {  // b - a = d / sigma
  std::array<double, 3> d;
  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    for (int i = 0; i < 3; ++i) r[i] = (b[i] - a[i] - T(d[static_cast<std::size_t>(i)])) / T(0.01);
    return true;
  }
};

// Ceres with the ordering solves the same problem to the same solution.
TEST(FillReducingOrdering, CeresSolvesTheSameWithIt) {
  constexpr int kNodes = 400, kHubs = 12;
  std::uniform_int_distribution<int> node(0, kNodes - 1);
  std::vector<std::array<double, 3>> truth_nodes(kNodes), truth_hubs(kHubs);
  for (int k = 0; k < kNodes; ++k)
    truth_nodes[k] = {0.05 * k, std::sin(0.03 * k), 0.1 * std::cos(0.01 * k)};
  for (int h = 0; h < kHubs; ++h) truth_hubs[h] = {2.0 * h, 1.0, 3.0};
  struct Problem {
    std::vector<std::array<double, 3>> nodes, hubs;
    std::unique_ptr<ceres::Problem> problem;
  };
  auto build = [&](unsigned measure_seed) {
    Problem q{truth_nodes, truth_hubs, std::make_unique<ceres::Problem>()};
    std::mt19937 m(measure_seed);
    std::normal_distribution<double> noise(0, 0.01);
    for (auto& n : q.nodes) n[1] += 0.1;  // a wrong start
    for (auto& h : q.hubs) h[2] -= 0.2;
    auto add = [&](double* a, double* b, const std::array<double, 3>& ta,
                   const std::array<double, 3>& tb) {
      Difference c;
      for (int i = 0; i < 3; ++i) c.d[static_cast<std::size_t>(i)] = tb[i] - ta[i] + noise(m);
      q.problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<Difference, 3, 3, 3>(new Difference(c)), nullptr, a, b);
    };
    for (int k = 0; k + 1 < kNodes; ++k)
      add(q.nodes[k].data(), q.nodes[k + 1].data(), truth_nodes[k], truth_nodes[k + 1]);
    for (int h = 0; h < kHubs; ++h) {
      for (int pass = 0; pass < 4; ++pass) {
        const int s = std::min(node(m), kNodes - 6);
        for (int k = s; k < s + 6; ++k)
          add(q.nodes[k].data(), q.hubs[h].data(), truth_nodes[k], truth_hubs[h]);
      }
    }
    q.nodes[0] = truth_nodes[0];
    q.problem->SetParameterBlockConstant(q.nodes[0].data());  // the gauge
    return q;
  };
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.function_tolerance = 1e-14;
  options.gradient_tolerance = 1e-14;
  options.parameter_tolerance = 1e-14;
  Problem plain = build(11), ordered = build(11);
  ceres::Solver::Summary s1, s2;
  ceres::Solve(options, plain.problem.get(), &s1);
  FillOrdering chosen;
  std::string message;
  auto ordering =
      solverOrdering(*ordered.problem, FillOrderingMethod::kNestedDissection, &chosen, &message);
  ASSERT_NE(ordering, nullptr) << message;
  EXPECT_EQ(ordering->NumElements(),
            ordered.problem->NumParameterBlocks());  // the constant one too
  EXPECT_EQ(chosen.order.size(),
            static_cast<std::size_t>(ordered.problem->NumParameterBlocks() - 1));
  options.linear_solver_ordering = ordering;
  ceres::Solve(options, ordered.problem.get(), &s2);
  ASSERT_TRUE(s1.IsSolutionUsable() && s2.IsSolutionUsable());
  EXPECT_EQ(s2.linear_solver_ordering_used.size(), chosen.order.size());
  double worst = 0;
  for (int k = 0; k < kNodes; ++k) {
    for (int i = 0; i < 3; ++i)
      worst = std::max(worst, std::abs(plain.nodes[k][i] - ordered.nodes[k][i]));
  }
  for (int h = 0; h < kHubs; ++h) {
    for (int i = 0; i < 3; ++i)
      worst = std::max(worst, std::abs(plain.hubs[h][i] - ordered.hubs[h][i]));
  }
  EXPECT_LT(worst, 1e-9);
  EXPECT_NEAR(s1.final_cost, s2.final_cost, 1e-9 * s1.final_cost);
  // AMD is Ceres' own ordering: none is given.
  FillOrdering amd;
  EXPECT_EQ(solverOrdering(*plain.problem, FillOrderingMethod::kAmd, &amd, &message), nullptr);
  EXPECT_TRUE(message.empty());
  EXPECT_EQ(amd.method, FillOrderingMethod::kAmd);
}

}  // namespace
}  // namespace lookboth
