// Stage `joint`: the drift model estimated from the data
// (estimate_drift_model; joint_adjustment.h). Factors on the configured
// sigmas of the relative motions' horizontal translation, vertical
// translation, tilt (roll, pitch) and yaw, by Helmert's variance component
// estimation after a round (and of the smooth motion's velocity and rate
// walks, where nodes were added between the input's samples): each group's
// factor is multiplied by sqrt(sum of its squared whitened residuals / its
// redundancy), the redundancy sum_i (1 - (J_i Cov J_i^T)_cc) over the
// group's residual components (what the other measurements leave to the
// trajectory's costs to decide), from the covariance of the nodes and scales
// on the pattern of the problem (selected inversion). Gap edges are left out.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <set>

#include "joint_adjustment.h"

namespace lookboth::joint_detail {

// A trajectory residual's whitened value `r` and its leverage J Cov J^T
// over its free blocks (tangent spaces); false when it cannot be evaluated.
bool JointAdjustment::leverageOf(const DriftResidual& d, const SparseCovariance& cov, double* r,
                                 Eigen::Matrix<double, 6, 6>& leverage) const {
  ceres::Problem& Q = *ceres_problem_;
  double ambient[3][6 * 7];  // the blocks are poses (7) or scales (1)
  double* jacobians[3] = {nullptr, nullptr, nullptr};
  int sizes[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i) {
    if (d.blocks[i] == nullptr) continue;
    sizes[i] = Q.ParameterBlockSize(d.blocks[i]);
    if (sizes[i] > 7) return false;
    if (Q.IsParameterBlockConstant(d.blocks[i])) continue;
    jacobians[i] = ambient[i];
  }
  if (!Q.GetCostFunctionForResidualBlock(d.id)->Evaluate(d.blocks.data(), r, jacobians)) {
    return false;
  }
  using RowMajor = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::Matrix<double, 6, Eigen::Dynamic> tangent[3];
  for (int i = 0; i < 3; ++i) {
    if (jacobians[i] == nullptr) continue;
    const Eigen::Map<const RowMajor> J(jacobians[i], 6, sizes[i]);
    if (const ceres::Manifold* m = Q.GetManifold(d.blocks[i]); m != nullptr) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> plus(m->AmbientSize(),
                                                                                  m->TangentSize());
      m->PlusJacobian(d.blocks[i], plus.data());
      tangent[i] = J * plus;
    } else {
      tangent[i] = J;
    }
  }
  leverage.setZero();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (jacobians[i] == nullptr || jacobians[j] == nullptr) continue;
      leverage += tangent[i] * cov.block(d.blocks[i], d.blocks[j]) * tangent[j].transpose();
    }
  }
  return true;
}

bool JointAdjustment::updateDriftModel() {
  ceres::Problem& Q = *ceres_problem_;
  lap();
  auto isFree = [&](const double* b) {
    return !Q.IsParameterBlockConstant(const_cast<double*>(b));
  };
  std::vector<std::pair<const double*, const double*>> pairs;
  std::set<std::pair<const double*, const double*>> seen;
  auto want = [&](const double* a, const double* b) {
    if (!isFree(a) || !isFree(b)) return;
    if (seen.count({b, a}) == 0 && seen.insert({a, b}).second) pairs.emplace_back(a, b);
  };
  for (const DriftResidual& d : drift_residuals_) {
    for (int i = 0; i < 3; ++i) {
      for (int j = i; j < 3; ++j) want(d.blocks[i], d.blocks[j]);
    }
  }
  // The blocks that touch many others are requested too, so that they go
  // to the dense group: their fill would make the factor 10x larger.
  for (const JointCamera& c : cameras_) want(c.pose, c.pose);
  want(x_params_, x_params_);
  prepareFramePoses();
  SparseCovariance cov;
  if (!cov.compute(pairs, &Q, options_.threads)) {
    result_.warnings.push_back("joint: the drift model could not be estimated (" + cov.message() +
                               "); the configured one was used, so the reported uncertainty "
                               "may not fit this trajectory's drift");
    drift_.failed = true;  // no further attempts
    return false;
  }
  constexpr int kGroups = DriftModelState::kGroups;
  double squares[kGroups] = {}, redundancy[kGroups] = {};
  // Residual component -> group: the drift model's, the smooth motion's.
  constexpr int kGroupOf[2][6] = {{0, 0, 1, 2, 2, 3}, {4, 4, 4, 5, 5, 5}};
  for (const DriftResidual& d : drift_residuals_) {
    double r[6];
    Eigen::Matrix<double, 6, 6> leverage;
    if (!leverageOf(d, cov, r, leverage)) continue;
    const Eigen::Matrix<double, 6, 1> h = leverage.diagonal();
    if (!h.allFinite() || h.maxCoeff() > 1 + 1e-6 || h.minCoeff() < -1e-9) continue;
    const int* group_of = kGroupOf[d.smooth ? 1 : 0];
    for (int c = 0; c < 6; ++c) {
      squares[group_of[c]] += r[c] * r[c];
      redundancy[group_of[c]] += 1 - h[c];
    }
  }
  bool changed = false;
  for (int g = 0; g < kGroups; ++g) {
    if (redundancy[g] < 10) continue;  // the data leave this group nothing to judge by
    const double step = std::sqrt(std::clamp(squares[g] / redundancy[g], 1e-4, 1e4));
    // A group moved the same way twice: its step squared. Helmert's
    // iteration converges linearly, slowly for a component the odometry
    // does not have (its factor tends to 0): on `paper_det` 4 updates reach
    // what the odometry's own model gives, where plain steps need 6.
    const bool again = drift_.updates > 0 && (step - 1) * (drift_.last_step[g] - 1) > 0;
    const double applied = again ? step * step : step;
    drift_.last_step[g] = step;
    drift_.factor[g] = std::clamp(drift_.factor[g] * applied, 1e-3, 1e3);
    changed |= std::abs(step - 1) > kDriftModelTolerance;
  }
  if (verbose_) {
    std::cerr << "joint drift model update " << drift_.updates + 1 << " (CPU " << lap() << " s"
              << cov.describe() << "): sigma factors horizontal " << drift_.factor[0]
              << ", vertical " << drift_.factor[1] << ", tilt " << drift_.factor[2] << ", yaw "
              << drift_.factor[3] << ", between samples " << drift_.factor[4] << " and "
              << drift_.factor[5] << " (redundancies " << redundancy[0] << ", " << redundancy[1]
              << ", " << redundancy[2] << ", " << redundancy[3] << ", " << redundancy[4] << ", "
              << redundancy[5] << ")\n";
  }
  return changed;
}

}  // namespace lookboth::joint_detail
