// SparseCovariance against ceres::Covariance on the same solved problems.
#include "../src/sparse_covariance.h"

#include <gtest/gtest.h>

#include <random>

#include "../src/pose_costs.h"

namespace lookboth {
namespace {

using calib_detail::SparseCovariance;

// A noisy measurement of b's position and rotation relative to a.
struct RelativePoseCost {
  Rigid3d a_from_b;
  double sigma_t = 0.01, sigma_r = 0.002;
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    const Rigid3<T> predicted =
        calib_detail::poseFromParams(a).inverse() * calib_detail::poseFromParams(b);
    const Eigen::Matrix<T, 6, 1> e = calib_detail::poseError(predicted, a_from_b);
    for (int i = 0; i < 6; ++i) residual[i] = e[i] / T(i < 3 ? sigma_t : sigma_r);
    return true;
  }
};

struct ScalarCost {
  double value = 0, sigma = 1;
  template <typename T>
  bool operator()(const T* x, const T* pose, T* residual) const {
    residual[0] = (x[0] * pose[0] - T(value)) / T(sigma);
    return true;
  }
};

// A chain of poses with loop edges, one scalar, robust losses on some edges.
struct Chain {
  std::vector<std::array<double, 7>> poses;
  double scalar = 1.0;
  std::unique_ptr<ceres::Problem> problem;
};

Chain makeChain(int n, bool fix_first, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  Chain c;
  std::vector<Rigid3d> truth;
  for (int i = 0; i < n; ++i) {
    truth.emplace_back(so3Exp(Eigen::Vector3d(0, 0, 0.3 * i)),
                       Eigen::Vector3d(std::cos(0.3 * i), std::sin(0.3 * i), 0.1 * i));
  }
  c.poses.resize(n);
  for (int i = 0; i < n; ++i) calib_detail::poseToParams(truth[i], c.poses[i].data());
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  c.problem = std::make_unique<ceres::Problem>(options);
  for (auto& p : c.poses)
    c.problem->AddParameterBlock(p.data(), 7, calib_detail::newPoseManifold());
  auto edge = [&](int i, int j, bool robust) {
    auto* cost = new RelativePoseCost;
    const Eigen::Vector3d dt(noise(rng), noise(rng), noise(rng));
    const Eigen::Vector3d dr(noise(rng), noise(rng), noise(rng));
    cost->a_from_b =
        truth[i].inverse() * truth[j] * Rigid3d(so3Exp(Eigen::Vector3d(dr * 0.002)), dt * 0.01);
    c.problem->AddResidualBlock(new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 7, 7>(cost),
                                robust ? new ceres::HuberLoss(1.0) : nullptr, c.poses[i].data(),
                                c.poses[j].data());
  };
  for (int i = 0; i + 1 < n; ++i) edge(i, i + 1, i % 3 == 0);
  for (int i = 0; i + 4 < n; i += 2) edge(i, i + 4, true);
  auto* s = new ScalarCost;
  s->value = c.poses[n - 1][0] * 1.02;
  s->sigma = 0.05;
  c.problem->AddResidualBlock(new ceres::AutoDiffCostFunction<ScalarCost, 1, 1, 7>(s), nullptr,
                              &c.scalar, c.poses[n - 1].data());
  if (fix_first) c.problem->SetParameterBlockConstant(c.poses[0].data());
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, c.problem.get(), &summary);
  return c;
}

TEST(SparseCovariance, MatchesCeresCovariance) {
  for (std::uint32_t seed = 1; seed <= 3; ++seed) {
    Chain c = makeChain(30, true, seed);
    std::vector<std::pair<const double*, const double*>> pairs;
    for (int i = 1; i < 30; i += 7) pairs.emplace_back(c.poses[i].data(), c.poses[i].data());
    pairs.emplace_back(c.poses[5].data(), c.poses[20].data());
    pairs.emplace_back(&c.scalar, &c.scalar);
    pairs.emplace_back(&c.scalar, c.poses[29].data());

    ceres::Covariance::Options options;
    options.algorithm_type = ceres::SPARSE_QR;
    ceres::Covariance reference(options);
    ASSERT_TRUE(reference.Compute(pairs, c.problem.get()));
    SparseCovariance ours;
    ASSERT_TRUE(ours.compute(pairs, c.problem.get())) << ours.message();
    for (const auto& [a, b] : pairs) {
      const int ra = c.problem->ParameterBlockTangentSize(a);
      const int rb = c.problem->ParameterBlockTangentSize(b);
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> expected(ra, rb);
      reference.GetCovarianceBlockInTangentSpace(a, b, expected.data());
      const Eigen::MatrixXd got = ours.block(a, b);
      ASSERT_EQ(got.rows(), ra);
      ASSERT_EQ(got.cols(), rb);
      const double scale = expected.cwiseAbs().maxCoeff();
      EXPECT_LT((got - expected).cwiseAbs().maxCoeff(), 1e-8 * scale)
          << "seed " << seed << "\nexpected\n"
          << expected << "\ngot\n"
          << got;
      // Either order.
      EXPECT_LT((ours.block(b, a) - Eigen::MatrixXd(expected.transpose())).cwiseAbs().maxCoeff(),
                1e-8 * scale);
    }
  }
}

TEST(SparseCovariance, ReportsAnUndeterminedDirection) {
  // Nothing fixes the gauge: every pose can move together.
  Chain c = makeChain(10, false, 4);
  SparseCovariance ours;
  const std::vector<std::pair<const double*, const double*>> pairs = {
      {c.poses[3].data(), c.poses[3].data()}};
  EXPECT_FALSE(ours.compute(pairs, c.problem.get()));
  EXPECT_NE(ours.message().find("singular"), std::string::npos) << ours.message();
}

TEST(SparseCovariance, RefusesAConstantBlock) {
  Chain c = makeChain(10, true, 5);
  SparseCovariance ours;
  const std::vector<std::pair<const double*, const double*>> pairs = {
      {c.poses[0].data(), c.poses[0].data()}};
  EXPECT_FALSE(ours.compute(pairs, c.problem.get()));
  EXPECT_NE(ours.message().find("constant"), std::string::npos) << ours.message();
}

}  // namespace
}  // namespace lookboth
