// serialiseOpenMpInThisThread (core/threads.h) keeps CHOLMOD's OpenMP teams on
// the calling thread. Its own executable: libgomp keeps the threads of a team
// once created, so the thread count is a witness only in a fresh process.
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "lookboth/core/threads.h"

namespace lookboth {
namespace {

int threadsOfThisProcess() {
  int n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator("/proc/self/task")) ++n;
  return n;
}

// r = a - b - c, 6-dimensional: every "point" tied to every "hub", so the
// normal equations have dense hub rows and CHOLMOD takes its supernodal path.
struct Difference {
  template <typename T>
  bool operator()(const T* a, const T* b, const T* c, T* r) const {
    for (int i = 0; i < 6; ++i) r[i] = a[i] - b[i] - c[i] - T(target[i]);
    return true;
  }
  double target[6];
};

TEST(OpenMpThreads, SparseFactorisationsStayOnTheCallingThread) {
  if (!ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE)) {
    GTEST_SKIP() << "Ceres without SuiteSparse";
  }
  const bool runtime = serialiseOpenMpInThisThread();
  if (!runtime) GTEST_SKIP() << "no OpenMP runtime in the process (CHOLMOD without OpenMP)";
  const int before = threadsOfThisProcess();

  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  std::vector<std::array<double, 6>> points(300), hubs(20);
  for (auto& p : points) p.fill(0);
  for (auto& h : hubs) h.fill(0);
  ceres::Problem problem;
  for (auto& p : points) {
    for (std::size_t h = 0; h < hubs.size(); ++h) {
      for (std::size_t g = h + 1; g < hubs.size(); g += 7) {
        auto* f = new Difference;
        for (double& t : f->target) t = normal(rng);
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Difference, 6, 6, 6, 6>(f),
                                 nullptr, p.data(), hubs[h].data(), hubs[g].data());
      }
    }
  }
  problem.SetParameterBlockConstant(hubs[0].data());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  options.num_threads = 1;
  options.max_num_iterations = 3;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();
  // Without the call CHOLMOD's supernodal factorisation starts teams of 4:
  // three more threads.
  EXPECT_EQ(threadsOfThisProcess(), before);
}

}  // namespace
}  // namespace lookboth
