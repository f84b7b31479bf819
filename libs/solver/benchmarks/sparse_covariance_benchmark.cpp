// SparseCovariance alone on the joint stage's shape (doc/benchmarks.md, "The covariance by selected
// inversion"): a chain of 10 nodes per camera along a loop driven twice, each camera seen from 3
// consecutive nodes of the first lap and 1 of the second through one global block (as
// fisheye_from_marker), each with a scalar (as its clock offset). Requested: each camera, each
// clock, each camera x clock, the global block. Arguments: cameras, route (1 Schur: all requested
// columns dense; 2 selected inversion).
#include <benchmark/benchmark.h>
#include <ceres/ceres.h>
#include <sys/resource.h>

#include <array>
#include <memory>
#include <random>
#include <vector>

#include "lookboth/geometry/random.h"
#include "lookboth/solver/pose_block.h"
#include "lookboth/solver/sparse_covariance.h"

namespace {

using namespace lookboth;

// residual = error of a^-1 * (b * c) against `measured`; c may be the
// identity (two blocks).
struct RelativeCost {
  Rigid3d measured;
  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* residual) const {
    const Rigid3<T> predicted =
        poseFromParams(a).inverse() * (poseFromParams(b) * poseFromParams(c));
    const Eigen::Matrix<T, 6, 1> e = poseError(predicted, measured);
    for (int i = 0; i < 6; ++i) residual[i] = e[i] / T(0.01);
    return true;
  }
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    const Rigid3<T> predicted = poseFromParams(a).inverse() * poseFromParams(b);
    const Eigen::Matrix<T, 6, 1> e = poseError(predicted, measured);
    for (int i = 0; i < 6; ++i) residual[i] = e[i] / T(0.01);
    return true;
  }
};

struct ClockCost {
  template <typename T>
  bool operator()(const T* clock, const T* camera, T* residual) const {
    residual[0] = (clock[0] - T(0.01) * camera[0]) / T(0.001);
    return true;
  }
};

struct Scene {
  std::vector<std::array<double, 7>> nodes, cameras;
  std::array<double, 7> global{};
  std::vector<double> clocks;
  ceres::Problem problem;
};

std::unique_ptr<Scene> makeScene(int cameras) {
  auto s = std::make_unique<Scene>();
  const int per_lap = 5 * cameras, n_nodes = 2 * per_lap;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  auto jitter = [&]() {
    const Eigen::Vector3d dt = drawVector<3>([&] { return noise(rng); }) * 0.01;
    const Eigen::Vector3d dr = drawVector<3>([&] { return noise(rng); }) * 0.01;
    return Rigid3d(so3Exp(dr), dt);
  };
  auto node = [&](int i) {
    const double a = 2 * M_PI * i / per_lap, r = 3.5 * cameras / (2 * M_PI);
    return Rigid3d(so3Exp(Eigen::Vector3d(0, 0, a + M_PI / 2)),
                   Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0));
  };
  s->nodes.resize(n_nodes);
  s->cameras.resize(cameras);
  s->clocks.assign(cameras, 0.0);
  for (int i = 0; i < n_nodes; ++i) poseToParams(node(i) * jitter(), s->nodes[i].data());
  const Rigid3d global(so3Exp(Eigen::Vector3d(0.1, 0.2, 0.3)), Eigen::Vector3d(0.1, 0, 0.2));
  poseToParams(global, s->global.data());
  for (auto& n : s->nodes) s->problem.AddParameterBlock(n.data(), 7, newPoseManifold());
  s->problem.AddParameterBlock(s->global.data(), 7, newPoseManifold());
  for (int i = 0; i + 1 < n_nodes; ++i) {
    auto* cost = new RelativeCost{node(i).inverse() * node(i + 1) * jitter()};
    s->problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativeCost, 6, 7, 7>(cost),
                                nullptr, s->nodes[i].data(), s->nodes[i + 1].data());
  }
  const Rigid3d above(so3Exp(Eigen::Vector3d(M_PI, 0, 0)), Eigen::Vector3d(0, 0, 3));
  for (int c = 0; c < cameras; ++c) {
    const int at = 5 * c;
    poseToParams(node(at) * above, s->cameras[c].data());
    s->problem.AddParameterBlock(s->cameras[c].data(), 7, newPoseManifold());
    for (const int k : {at, at + 1, at + 2, at + per_lap}) {
      auto* cost =
          new RelativeCost{global.inverse() * node(k).inverse() * node(at) * above * jitter()};
      s->problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativeCost, 6, 7, 7, 7>(cost),
                                  nullptr, s->global.data(), s->nodes[k].data(),
                                  s->cameras[c].data());
    }
    s->problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ClockCost, 1, 1, 7>(new ClockCost),
                                nullptr, &s->clocks[c], s->cameras[c].data());
  }
  // A prior on the global block (nodes[0] is held): alone, the sightings
  // leave it a turn and a shift about the vertical.
  auto* prior = new RelativeCost{node(0).inverse() * global * jitter()};
  s->problem.AddResidualBlock(new ceres::AutoDiffCostFunction<RelativeCost, 6, 7, 7>(prior),
                              nullptr, s->nodes[0].data(), s->global.data());
  s->problem.SetParameterBlockConstant(s->nodes[0].data());
  return s;
}

void BM_SparseCovariance(benchmark::State& state) {
  const int cameras = static_cast<int>(state.range(0));
  const auto method = state.range(1) == 1 ? SparseCovariance::Method::kSchur
                                          : SparseCovariance::Method::kSelectedInversion;
  const std::unique_ptr<Scene> scene = makeScene(cameras);
  std::vector<std::pair<const double*, const double*>> pairs;
  for (int c = 0; c < cameras; ++c) {
    pairs.emplace_back(scene->cameras[c].data(), scene->cameras[c].data());
    pairs.emplace_back(&scene->clocks[c], &scene->clocks[c]);
    pairs.emplace_back(scene->cameras[c].data(), &scene->clocks[c]);
  }
  pairs.emplace_back(scene->global.data(), scene->global.data());
  SparseCovariance covariance;
  for (auto _ : state) {
    if (!covariance.compute(pairs, &scene->problem, 1, method)) {
      state.SkipWithError(covariance.message().c_str());
      return;
    }
  }
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  state.counters["dense_columns"] = covariance.stats().dense_columns;
  state.counters["sparse_columns"] = covariance.stats().sparse_columns;
  state.counters["factor_nonzeros"] = static_cast<double>(covariance.stats().factor_nonzeros);
  state.counters["peak_rss_MiB"] = static_cast<double>(usage.ru_maxrss) / 1024.0;
}
BENCHMARK(BM_SparseCovariance)
    ->ArgsProduct({{100, 300, 1000, 3000}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->Iterations(1);

}  // namespace

BENCHMARK_MAIN();
