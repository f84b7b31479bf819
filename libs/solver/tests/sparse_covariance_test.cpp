// SparseCovariance against ceres::Covariance on the same solved problems.
#include "lookboth/solver/sparse_covariance.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "lookboth/geometry/random.h"
#include "lookboth/solver/pose_block.h"

namespace lookboth {
namespace {

// A noisy measurement of b's position and rotation relative to a.
struct RelativePoseCost {
  Rigid3d a_from_b;
  double sigma_t = 0.01, sigma_r = 0.002;
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    const Rigid3<T> predicted = poseFromParams(a).inverse() * poseFromParams(b);
    const Eigen::Matrix<T, 6, 1> e = poseError(predicted, a_from_b);
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
  for (int i = 0; i < n; ++i) poseToParams(truth[i], c.poses[i].data());
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  c.problem = std::make_unique<ceres::Problem>(options);
  for (auto& p : c.poses) c.problem->AddParameterBlock(p.data(), 7, newPoseManifold());
  auto edge = [&](int i, int j, bool robust) {
    auto* cost = new RelativePoseCost;
    const Eigen::Vector3d dt = drawVector<3>([&] { return noise(rng); });
    const Eigen::Vector3d dr = drawVector<3>([&] { return noise(rng); });
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

using Pairs = std::vector<std::pair<const double*, const double*>>;
constexpr SparseCovariance::Method kMethods[] = {SparseCovariance::Method::kSelectedInversion,
                                                 SparseCovariance::Method::kSchur};

// Every requested block of `ours` equals ceres::Covariance's (SPARSE_QR) to
// 1e-8 of the block's largest entry, in either order.
void expectMatchesCeres(const Pairs& pairs, ceres::Problem* problem, const SparseCovariance& ours,
                        const ceres::Covariance& reference, const std::string& what) {
  for (const auto& [a, b] : pairs) {
    const int ra = problem->ParameterBlockTangentSize(a);
    const int rb = problem->ParameterBlockTangentSize(b);
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> expected(ra, rb);
    ASSERT_TRUE(reference.GetCovarianceBlockInTangentSpace(a, b, expected.data()));
    const Eigen::MatrixXd got = ours.block(a, b);
    ASSERT_EQ(got.rows(), ra);
    ASSERT_EQ(got.cols(), rb);
    const double scale = expected.cwiseAbs().maxCoeff();
    EXPECT_LT((got - expected).cwiseAbs().maxCoeff(), 1e-8 * scale) << what << "\nexpected\n"
                                                                    << expected << "\ngot\n"
                                                                    << got;
    EXPECT_LT((ours.block(b, a) - Eigen::MatrixXd(expected.transpose())).cwiseAbs().maxCoeff(),
              1e-8 * scale)
        << what;
  }
}

ceres::Covariance::Options referenceOptions() {
  ceres::Covariance::Options options;
  options.algorithm_type = ceres::SPARSE_QR;
  return options;
}

TEST(SparseCovariance, MatchesCeresCovariance) {
  for (std::uint32_t seed = 1; seed <= 3; ++seed) {
    Chain c = makeChain(30, true, seed);
    Pairs pairs;
    for (int i = 1; i < 30; i += 7) pairs.emplace_back(c.poses[i].data(), c.poses[i].data());
    pairs.emplace_back(c.poses[5].data(), c.poses[20].data());
    pairs.emplace_back(&c.scalar, &c.scalar);
    pairs.emplace_back(&c.scalar, c.poses[29].data());

    ceres::Covariance reference(referenceOptions());
    ASSERT_TRUE(reference.Compute(pairs, c.problem.get()));
    for (const auto method : kMethods) {
      SparseCovariance ours;
      ASSERT_TRUE(ours.compute(pairs, c.problem.get(), 1, method)) << ours.message();
      expectMatchesCeres(
          pairs, c.problem.get(), ours, reference,
          "seed " + std::to_string(seed) + " method " + std::to_string(static_cast<int>(method)));
    }
  }
}

// The joint stage's shape, larger: a long chain of nodes; cameras, each seen
// from several nodes (some far apart along the chain) through one global
// block (as fisheye_from_marker), each with a scalar (as its clock offset);
// segment scalars (as scales) on runs of nodes, tied by a random walk.
struct Facility {
  std::vector<std::array<double, 7>> nodes, cameras;
  std::array<double, 7> global{};
  std::vector<double> clocks, scales;
  std::unique_ptr<ceres::Problem> problem;
};

// A noisy measurement of the camera relative to node * global.
struct SightCost {
  Rigid3d measured;
  template <typename T>
  bool operator()(const T* node, const T* global, const T* camera, T* residual) const {
    const Rigid3<T> predicted =
        (poseFromParams(node) * poseFromParams(global)).inverse() * poseFromParams(camera);
    const Eigen::Matrix<T, 6, 1> e = poseError(predicted, measured);
    for (int i = 0; i < 6; ++i) residual[i] = e[i] / T(i < 3 ? 0.02 : 0.01);
    return true;
  }
};

struct PoseErrorCost {
  Rigid3d measured;
  double sigma = 1;
  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    const Eigen::Matrix<T, 6, 1> e = poseError(poseFromParams(pose), measured);
    for (int i = 0; i < 6; ++i) residual[i] = e[i] / T(sigma);
    return true;
  }
};

struct DifferenceCost {
  double sigma = 1;
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    residual[0] = (a[0] - b[0]) / T(sigma);
    return true;
  }
};

Facility makeFacility(int n_nodes, int n_cameras, int n_scales, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_int_distribution<int> any_node(1, n_nodes - 1);
  auto jitter = [&](double t, double r) {
    const Eigen::Vector3d dt = drawVector<3>([&] { return noise(rng); }) * t;
    const Eigen::Vector3d dr = drawVector<3>([&] { return noise(rng); }) * r;
    return Rigid3d(so3Exp(dr), dt);
  };
  Facility f;
  std::vector<Rigid3d> node_truth, camera_truth;
  for (int i = 0; i < n_nodes; ++i) {
    const double s = 0.05 * i;
    node_truth.emplace_back(
        so3Exp(Eigen::Vector3d(0.2 * std::sin(s), 0.1 * std::cos(2 * s), s)),
        Eigen::Vector3d(10 * std::cos(s), 10 * std::sin(s), 0.3 * std::sin(3 * s)));
  }
  const Rigid3d global_truth(so3Exp(Eigen::Vector3d(0.1, -0.2, 0.3)), Eigen::Vector3d(0.1, 0, 0.2));
  for (int c = 0; c < n_cameras; ++c) {
    camera_truth.push_back(node_truth[any_node(rng)] * global_truth * jitter(1.0, 0.3));
  }
  f.nodes.resize(n_nodes);
  f.cameras.resize(n_cameras);
  f.clocks.assign(n_cameras, 0.0);
  f.scales.assign(n_scales, 1.0);
  for (int i = 0; i < n_nodes; ++i) poseToParams(node_truth[i], f.nodes[i].data());
  for (int c = 0; c < n_cameras; ++c) {
    poseToParams(camera_truth[c], f.cameras[c].data());
  }
  poseToParams(global_truth, f.global.data());
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
  f.problem = std::make_unique<ceres::Problem>(options);
  for (auto& p : f.nodes) f.problem->AddParameterBlock(p.data(), 7, newPoseManifold());
  for (auto& p : f.cameras) {
    f.problem->AddParameterBlock(p.data(), 7, newPoseManifold());
  }
  f.problem->AddParameterBlock(f.global.data(), 7, newPoseManifold());
  // The chain, with a few loop edges.
  auto relative = [&](int i, int j, bool robust) {
    auto* cost = new RelativePoseCost;
    cost->a_from_b = node_truth[i].inverse() * node_truth[j] * jitter(0.01, 0.002);
    f.problem->AddResidualBlock(new ceres::AutoDiffCostFunction<RelativePoseCost, 6, 7, 7>(cost),
                                robust ? new ceres::HuberLoss(1.0) : nullptr, f.nodes[i].data(),
                                f.nodes[j].data());
  };
  for (int i = 0; i + 1 < n_nodes; ++i) relative(i, i + 1, i % 5 == 0);
  for (int i = 0; i + 40 < n_nodes; i += 37) relative(i, i + 40, true);
  // Cameras: 3 to 5 sightings, from a run of nodes and from a far node.
  std::uniform_int_distribution<int> sightings(3, 5);
  for (int c = 0; c < n_cameras; ++c) {
    const int start = any_node(rng);
    const int count = sightings(rng);
    for (int k = 0; k < count; ++k) {
      const int node = k + 1 < count ? std::min(n_nodes - 1, start + k) : any_node(rng);
      auto* cost = new SightCost;
      cost->measured =
          (node_truth[node] * global_truth).inverse() * camera_truth[c] * jitter(0.02, 0.01);
      f.problem->AddResidualBlock(new ceres::AutoDiffCostFunction<SightCost, 6, 7, 7, 7>(cost),
                                  k % 2 ? new ceres::CauchyLoss(2.0) : nullptr,
                                  f.nodes[node].data(), f.global.data(), f.cameras[c].data());
    }
    auto* clock = new ScalarCost;
    clock->value = f.cameras[c][0] * (1 + 0.01 * noise(rng));
    clock->sigma = 0.1;
    f.problem->AddResidualBlock(new ceres::AutoDiffCostFunction<ScalarCost, 1, 1, 7>(clock),
                                nullptr, &f.clocks[c], f.cameras[c].data());
  }
  auto* prior = new PoseErrorCost;
  prior->measured = global_truth * jitter(0.01, 0.01);
  prior->sigma = 0.05;
  f.problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PoseErrorCost, 6, 7>(prior), nullptr,
                              f.global.data());
  // Scales on runs of nodes, a random walk between neighbours.
  for (int s = 0; s < n_scales; ++s) {
    for (int i = s * n_nodes / n_scales; i < (s + 1) * n_nodes / n_scales; i += 3) {
      auto* cost = new ScalarCost;
      cost->value = f.nodes[i][0] * (1 + 0.01 * noise(rng));
      cost->sigma = 0.2;
      f.problem->AddResidualBlock(new ceres::AutoDiffCostFunction<ScalarCost, 1, 1, 7>(cost),
                                  new ceres::HuberLoss(1.0), &f.scales[s], f.nodes[i].data());
    }
    if (s > 0) {
      auto* walk = new DifferenceCost;
      walk->sigma = 0.05;
      f.problem->AddResidualBlock(new ceres::AutoDiffCostFunction<DifferenceCost, 1, 1, 1>(walk),
                                  nullptr, &f.scales[s - 1], &f.scales[s]);
    }
  }
  f.problem->SetParameterBlockConstant(f.nodes[0].data());
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = 20;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, f.problem.get(), &summary);
  return f;
}

TEST(SparseCovariance, MatchesCeresCovarianceOnALargeStructure) {
  for (std::uint32_t seed = 11; seed <= 12; ++seed) {
    Facility f = makeFacility(600, 150, 6, seed);
    // As the joint stage asks: each camera, its clock and camera x clock,
    // the global block, all pairs of scales; and a few others.
    Pairs pairs;
    for (std::size_t c = 0; c < f.cameras.size(); ++c) {
      pairs.emplace_back(f.cameras[c].data(), f.cameras[c].data());
      pairs.emplace_back(&f.clocks[c], &f.clocks[c]);
      if (c % 2) pairs.emplace_back(f.cameras[c].data(), &f.clocks[c]);
    }
    pairs.emplace_back(f.global.data(), f.global.data());
    pairs.emplace_back(f.cameras[3].data(), f.global.data());
    for (std::size_t i = 0; i < f.scales.size(); ++i) {
      for (std::size_t j = i; j < f.scales.size(); ++j)
        pairs.emplace_back(&f.scales[i], &f.scales[j]);
    }
    pairs.emplace_back(f.nodes[100].data(), f.nodes[100].data());
    pairs.emplace_back(f.nodes[100].data(), f.nodes[101].data());
    pairs.emplace_back(f.nodes[7].data(), f.cameras[9].data());  // not coupled by H

    ceres::Covariance reference(referenceOptions());
    ASSERT_TRUE(reference.Compute(pairs, f.problem.get()));
    for (const auto method : kMethods) {
      SparseCovariance ours;
      ASSERT_TRUE(ours.compute(pairs, f.problem.get(), 1, method)) << ours.message();
      if (method != SparseCovariance::Method::kSchur) {
        // Dense: the global block, the scales, node 7 and camera 9 (unless
        // it happens to see node 7).
        EXPECT_EQ(ours.stats().method, SparseCovariance::Method::kSelectedInversion);
        EXPECT_GE(ours.stats().dense_columns, 6 + 6);
        EXPECT_LE(ours.stats().dense_columns, 6 + 6 + 6 + 6);
      }
      expectMatchesCeres(
          pairs, f.problem.get(), ours, reference,
          "seed " + std::to_string(seed) + " method " + std::to_string(static_cast<int>(method)));
    }
  }
}

// The whole columns of H^-1 for dense blocks (requestWholeColumns): every
// free block's rows in them are its covariance with those blocks, as
// ceres::Covariance gives them; a block not in the dense group keeps none.
TEST(SparseCovariance, KeepsWholeColumnsOfTheDenseBlocks) {
  Facility f = makeFacility(600, 150, 6, 11);
  Pairs pairs;  // as the joint stage asks for the aligned prediction: camera pairs, dense
  for (std::size_t a = 0; a < f.cameras.size(); ++a) {
    for (std::size_t b = a; b < f.cameras.size(); ++b) {
      pairs.emplace_back(f.cameras[a].data(), f.cameras[b].data());
    }
  }
  std::vector<const double*> whole;
  for (const auto& camera : f.cameras) whole.push_back(camera.data());
  SparseCovariance ours;
  ours.requestWholeColumns(whole);
  ASSERT_TRUE(ours.compute(pairs, f.problem.get())) << ours.message();
  const Eigen::MatrixXd& y = ours.wholeColumns();
  ASSERT_EQ(y.cols(), 6 * static_cast<Eigen::Index>(f.cameras.size()));
  const std::vector<const double*> rows = {f.nodes[5].data(), f.nodes[100].data(),
                                           f.global.data(),   &f.scales[0],
                                           &f.clocks[2],      f.cameras[4].data()};
  Pairs reference_pairs;
  for (const double* r : rows) {
    for (const double* c : whole) reference_pairs.emplace_back(r, c);
  }
  ceres::Covariance reference(referenceOptions());
  ASSERT_TRUE(reference.Compute(reference_pairs, f.problem.get()));
  for (const double* r : rows) {
    const int size = f.problem->ParameterBlockTangentSize(r);
    ASSERT_GE(ours.wholeRow(r), 0);
    for (std::size_t c = 0; c < whole.size(); ++c) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> expected(size, 6);
      ASSERT_TRUE(reference.GetCovarianceBlockInTangentSpace(r, whole[c], expected.data()));
      const Eigen::MatrixXd got =
          y.block(ours.wholeRow(r), 6 * static_cast<Eigen::Index>(c), size, 6);
      const double scale = expected.cwiseAbs().maxCoeff();
      EXPECT_LT((got - expected).cwiseAbs().maxCoeff(), 1e-8 * scale) << "camera " << c;
    }
  }
  EXPECT_EQ(ours.wholeRow(f.nodes[0].data()), -1);  // the gauge: constant
  // A requested block outside the dense group: no columns kept.
  SparseCovariance sparse_only;
  sparse_only.requestWholeColumns({f.nodes[100].data()});
  ASSERT_TRUE(sparse_only.compute({{f.nodes[100].data(), f.nodes[100].data()}}, f.problem.get()));
  EXPECT_EQ(sparse_only.wholeColumns().size(), 0);
}

// A request whose dense part (W over the requested sparse blocks and the
// dense group) exceeds the limit fails with a message instead of allocating.
TEST(SparseCovariance, RefusesADensePartOverItsLimit) {
  Facility f = makeFacility(600, 150, 6, 11);
  Pairs pairs = {{f.global.data(), f.global.data()}};
  for (std::size_t k = 1; k < f.nodes.size(); ++k) {  // node 0: the gauge, constant
    pairs.emplace_back(f.nodes[k].data(), f.nodes[k].data());
  }
  SparseCovariance ours;
  ASSERT_TRUE(ours.compute(pairs, f.problem.get())) << ours.message();
  ours.setMaxDenseEntries(1000);
  EXPECT_FALSE(ours.compute(pairs, f.problem.get()));
  EXPECT_NE(ours.message().find("MiB"), std::string::npos) << ours.message();
}

TEST(SparseCovariance, ReportsAnUndeterminedDirection) {
  // Nothing fixes the gauge: every pose can move together.
  Chain c = makeChain(10, false, 4);
  const Pairs pairs = {{c.poses[3].data(), c.poses[3].data()}};
  for (const auto method : kMethods) {
    SparseCovariance ours;
    EXPECT_FALSE(ours.compute(pairs, c.problem.get(), 1, method));
    EXPECT_NE(ours.message().find("singular"), std::string::npos) << ours.message();
  }
}

TEST(SparseCovariance, RefusesAConstantBlock) {
  Chain c = makeChain(10, true, 5);
  const Pairs pairs = {{c.poses[0].data(), c.poses[0].data()}};
  for (const auto method : kMethods) {
    SparseCovariance ours;
    EXPECT_FALSE(ours.compute(pairs, c.problem.get(), 1, method));
    EXPECT_NE(ours.message().find("constant"), std::string::npos) << ours.message();
  }
}

}  // namespace
}  // namespace lookboth
