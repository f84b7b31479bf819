// Bundle adjustment on bearings and the Sim(3) pose graph, in Ceres.
#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "lookboth/core/threads.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/vo/bearing_geometry.h"
#include "map.h"

namespace lookboth::vo {
namespace {

/// Reprojection error on the tangent plane of the measured bearing f:
///   p_c = R^T (X - C)   (R, C: world_from_camera rotation and camera centre)
///   r   = focal * [b1.p_c; b2.p_c] / (f.p_c)
/// i.e. the gnomonic projection of the predicted direction onto the plane
/// tangent to the unit sphere at f, in pixels (focal in px/rad). It is
/// defined for any incidence angle (beyond 90 deg too) and grows without
/// bound as the prediction turns 90 deg away from f; the denominator is
/// floored so that a gross outlier gives a large but finite residual.
struct TangentResidual {
  TangentResidual(const Eigen::Vector3d& bearing, double focal)
      : f(bearing.normalized()), basis(tangentBasis(bearing)), focal(focal) {}

  template <typename T>
  bool operator()(const T* q_world_from_camera, const T* c_in_world, const T* p_in_world,
                  T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_world_from_camera);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> c(c_in_world);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(p_in_world);
    const Eigen::Matrix<T, 3, 1> p_c = q.conjugate() * (p - c);
    T depth = f.cast<T>().dot(p_c);
    const T floor = T(0.1) * p_c.norm();
    if (depth < floor) depth = floor;
    const Eigen::Matrix<T, 2, 1> tangent = basis.cast<T>() * p_c;
    residual[0] = T(focal) * tangent(0) / depth;
    residual[1] = T(focal) * tangent(1) / depth;
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector3d& bearing, double focal) {
    return new ceres::AutoDiffCostFunction<TangentResidual, 2, 4, 3, 3>(
        new TangentResidual(bearing, focal));
  }

  Eigen::Vector3d f;
  Eigen::Matrix<double, 2, 3> basis;
  double focal;
};

/// Sim(3) relative-pose error: D = Z^-1 * (T_from^-1 * T_to), residual
/// [D.translation; log(D.rotation); log(D.scale)] * weight. Parameters per
/// node: quaternion (4), translation (3), log scale (1).
struct Sim3EdgeResidual {
  explicit Sim3EdgeResidual(const Sim3d& measured, double weight)
      : measured_inverse(measured.inverse()), weight(weight) {}

  template <typename T>
  bool operator()(const T* q_from, const T* t_from, const T* s_from, const T* q_to, const T* t_to,
                  const T* s_to, T* residual) const {
    using std::exp;
    using std::log;
    const Sim3<T> world_from_a(exp(s_from[0]), Eigen::Map<const Eigen::Quaternion<T>>(q_from),
                               Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t_from));
    const Sim3<T> world_from_b(exp(s_to[0]), Eigen::Map<const Eigen::Quaternion<T>>(q_to),
                               Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t_to));
    const Sim3<T> z_inv(T(measured_inverse.scale), measured_inverse.rotation.cast<T>(),
                        measured_inverse.translation.cast<T>());
    const Sim3<T> d = z_inv * (world_from_a.inverse() * world_from_b);
    const Eigen::Matrix<T, 3, 1> w = so3Log(d.rotation);
    for (int i = 0; i < 3; ++i) {
      residual[i] = T(weight) * d.translation(i);
      residual[3 + i] = T(weight) * w(i);
    }
    residual[6] = T(weight) * log(d.scale);
    return true;
  }

  static ceres::CostFunction* Create(const Sim3d& measured, double weight) {
    return new ceres::AutoDiffCostFunction<Sim3EdgeResidual, 7, 4, 3, 1, 4, 3, 1>(
        new Sim3EdgeResidual(measured, weight));
  }

  Sim3d measured_inverse;
  double weight;
};

}  // namespace

int bundleAdjust(Map& map, const std::set<int>& variable, const std::set<int>& fixed,
                 const AdjustmentOptions& options, ObservationScope scope, AdjustmentReport* report,
                 const std::set<int>* only_landmarks) {
  const bool variable_observations_only = scope == ObservationScope::kVariableKeyframes;
  const auto used = [&](const Observation& o) {
    return !variable_observations_only || variable.count(o.keyframe) > 0;
  };
  const auto checked = [&](const Observation& o) {
    return scope == ObservationScope::kAll || variable.count(o.keyframe) > 0;
  };
  // Parameter blocks: per keyframe [qx qy qz qw] and camera centre; per landmark its point.
  struct Pose {
    Eigen::Quaterniond q;
    Eigen::Vector3d c;
  };
  std::map<int, Pose> poses;
  std::set<int> landmark_ids;
  for (int k : variable) {
    for (int l : map.keyframes[k].landmarks) {
      if (map.landmarks[l].valid && (!only_landmarks || only_landmarks->count(l)))
        landmark_ids.insert(l);
    }
  }
  if (variable_observations_only) {
    // A point seen by one of them would only pin that keyframe to where the
    // point was: left out.
    for (auto it = landmark_ids.begin(); it != landmark_ids.end();) {
      const auto& observations = map.landmarks[size_t(*it)].observations;
      it = std::count_if(observations.begin(), observations.end(), used) < 2
               ? landmark_ids.erase(it)
               : std::next(it);
    }
  }
  if (landmark_ids.empty()) return 0;

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold quaternion_manifold;
  ceres::HuberLoss* loss = new ceres::HuberLoss(options.huber_px);

  auto pose_of = [&](int k) -> Pose& {
    auto it = poses.find(k);
    if (it == poses.end()) {
      const Rigid3d& w = map.keyframes[k].world_from_camera;
      it = poses.emplace(k, Pose{w.rotation, w.translation}).first;
    }
    return it->second;
  };
  int residuals = 0;
  for (int l : landmark_ids) {
    Landmark& landmark = map.landmarks[l];
    for (const Observation& o : landmark.observations) {
      if (!used(o)) continue;
      Pose& pose = pose_of(o.keyframe);
      problem.AddResidualBlock(TangentResidual::Create(o.bearing, options.focal_px), loss,
                               pose.q.coeffs().data(), pose.c.data(), landmark.p_in_world.data());
      ++residuals;
    }
  }
  for (auto& [k, pose] : poses) {
    problem.SetManifold(pose.q.coeffs().data(), &quaternion_manifold);
    if (!variable.count(k) || fixed.count(k)) {
      problem.SetParameterBlockConstant(pose.q.coeffs().data());
      problem.SetParameterBlockConstant(pose.c.data());
    }
  }
  // Landmarks seen by a single keyframe only have no depth constraint: hold them.
  for (int l : landmark_ids) {
    const auto& observations = map.landmarks[l].observations;
    if (std::count_if(observations.begin(), observations.end(), used) < 2) {
      problem.SetParameterBlockConstant(map.landmarks[l].p_in_world.data());
    }
  }

  if (report) {
    ++report->problems;
    report->largest_residual_blocks = std::max(report->largest_residual_blocks, residuals);
    report->largest_keyframes = std::max(report->largest_keyframes, static_cast<int>(poses.size()));
  }

  ceres::Solver::Options solver;
  solver.linear_solver_type = variable.size() <= 20 ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  if (options.implicit_schur) {
    solver.linear_solver_type = ceres::ITERATIVE_SCHUR;
    solver.preconditioner_type = ceres::SCHUR_JACOBI;
  }
  solver.max_num_iterations = options.iterations;
  solver.num_threads = options.threads;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  serialiseOpenMpInThisThread();  // CHOLMOD's teams of 4 (core/threads.h)
  ceres::Solve(solver, &problem, &summary);
  delete loss;

  for (auto& [k, pose] : poses) {
    if (!variable.count(k) || fixed.count(k)) continue;
    map.keyframes[k].world_from_camera = Rigid3d(pose.q.normalized(), pose.c);
  }
  // Drop observations that stay far off, and landmarks left with fewer than two.
  const double outlier_rad = options.outlier_px / options.focal_px;
  int removed = 0;
  for (int l : landmark_ids) {
    Landmark& landmark = map.landmarks[l];
    std::vector<Observation> kept;
    for (const Observation& o : landmark.observations) {
      if (!checked(o)) {
        kept.push_back(o);
        continue;
      }
      const Rigid3d camera_from_world = map.keyframes[o.keyframe].world_from_camera.inverse();
      if (angularError(o.bearing, camera_from_world * landmark.p_in_world) < outlier_rad) {
        kept.push_back(o);
      } else {
        ++removed;
      }
    }
    if (kept.size() < 2) {
      // Invalid for good: nothing of it is kept but its slot.
      landmark.valid = false;
      kept.clear();
      kept.shrink_to_fit();
    }
    landmark.observations.swap(kept);
  }
  return removed;
}

int bundleAdjustWindowed(Map& map, const std::set<int>& ids, int gauge, int window, int sweeps,
                         const AdjustmentOptions& options, AdjustmentReport* report) {
  if (window <= 0 || static_cast<int>(ids.size()) <= window) {
    return bundleAdjust(map, ids, {gauge}, options, ObservationScope::kAll, report);
  }
  const std::vector<int> order(ids.begin(), ids.end());
  const size_t n = order.size();
  const size_t size = static_cast<size_t>(window);
  const size_t stride = std::max<size_t>(1, size / 2);
  int removed = 0;

  // 1. Coarse: every step-th keyframe (and the last), their observations only.
  {
    const size_t step = (n + size - 2) / (size - 1);
    std::vector<size_t> picked;
    for (size_t i = 0; i < n; i += step) picked.push_back(i);
    if (picked.back() != n - 1) picked.push_back(n - 1);
    std::set<int> coarse;
    for (size_t i : picked) coarse.insert(order[i]);
    std::map<int, Rigid3d> before;
    for (int k : ids) before[k] = map.keyframes[size_t(k)].world_from_camera;
    // The outlier check waits for the fine pass (the others have not moved yet).
    AdjustmentOptions coarse_options = options;
    coarse_options.outlier_px = std::numeric_limits<double>::infinity();
    bundleAdjust(map, coarse, {gauge}, coarse_options, ObservationScope::kVariableKeyframes,
                 report);
    // new world from old world, per keyframe: picked ones from the solve,
    // the ones between interpolated.
    std::map<int, Rigid3d> correction;
    const auto solved = [&](size_t i) {
      const int k = order[i];
      return map.keyframes[size_t(k)].world_from_camera * before[k].inverse();
    };
    for (size_t j = 0; j + 1 < picked.size(); ++j) {
      const Rigid3d a = solved(picked[j]), b = solved(picked[j + 1]);
      for (size_t i = picked[j]; i <= picked[j + 1]; ++i) {
        const double alpha = double(i - picked[j]) / double(picked[j + 1] - picked[j]);
        correction[order[i]] = interpolateLinearSlerp(a, b, alpha);
      }
    }
    std::set<int> coarse_landmarks;
    {
      // The landmarks the coarse solve moved: those two or more of its keyframes see.
      std::map<int, int> seen;
      for (int k : coarse) {
        for (int l : map.keyframes[size_t(k)].landmarks) ++seen[l];
      }
      for (const auto& [l, count] : seen) {
        if (count >= 2) coarse_landmarks.insert(l);
      }
    }
    for (size_t l = 0; l < map.landmarks.size(); ++l) {
      Landmark& landmark = map.landmarks[l];
      if (!landmark.valid || coarse_landmarks.count(int(l))) continue;
      const auto it = correction.find(landmark.reference_keyframe);
      if (it != correction.end()) landmark.p_in_world = it->second * landmark.p_in_world;
    }
    for (int k : ids) {
      if (!coarse.count(k)) map.keyframes[size_t(k)].world_from_camera = correction[k] * before[k];
    }
  }

  // 2. Fine: overlapping windows of consecutive keyframes.
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (size_t begin = 0; begin < n; begin += stride) {
      // The last window is a full one ending at the last keyframe.
      const size_t end = std::min(n, begin + size);
      const size_t first = end - std::min(n, size);
      const std::set<int> variable(order.begin() + static_cast<std::ptrdiff_t>(first),
                                   order.begin() + static_cast<std::ptrdiff_t>(end));
      std::set<int> fixed;
      if (variable.count(gauge)) fixed.insert(gauge);
      // Only the window's own observations are checked for outliers: the
      // keyframes around it may not be refined yet.
      removed += bundleAdjust(map, variable, fixed, options,
                              ObservationScope::kCheckVariableKeyframes, report);
      if (end == n) break;
    }
  }
  return removed;
}

int bundleAdjustSampled(Map& map, const std::set<int>& ids, int gauge,
                        const ObservationBudget& budget, const AdjustmentOptions& options,
                        AdjustmentReport* report) {
  // The landmarks the one problem would hold, and its size.
  std::vector<std::pair<int, int>> candidates;  // (observations, landmark)
  std::set<int> seen;
  std::size_t total = 0;
  for (int k : ids) {
    for (int l : map.keyframes[size_t(k)].landmarks) {
      const Landmark& landmark = map.landmarks[size_t(l)];
      if (!landmark.valid || !seen.insert(l).second) continue;
      const int n = static_cast<int>(landmark.observations.size());
      total += size_t(n);
      if (n >= 2) candidates.emplace_back(n, l);
    }
  }
  if (budget.max_observations <= 0 || total <= size_t(budget.max_observations)) {
    return bundleAdjust(map, ids, {gauge}, options, ObservationScope::kAll, report);
  }
  // Longest tracks first (the widest baselines, and the points seen again
  // across a loop); a landmark is taken while one of its keyframes has fewer
  // than `quota` observations taken.
  const int quota = std::max(budget.min_per_keyframe,
                             budget.max_observations / std::max<int>(1, int(ids.size())));
  std::sort(candidates.begin(), candidates.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  std::map<int, int> taken;  // per keyframe of ids
  std::set<int> selected;
  for (const auto& [n, l] : candidates) {
    const auto& observations = map.landmarks[size_t(l)].observations;
    const bool wanted = std::any_of(observations.begin(), observations.end(), [&](const auto& o) {
      return ids.count(o.keyframe) && taken[o.keyframe] < quota;
    });
    if (!wanted) continue;
    selected.insert(l);
    for (const Observation& o : observations) ++taken[o.keyframe];
  }
  std::map<int, Rigid3d> before;
  for (int k : ids) before[k] = map.keyframes[size_t(k)].world_from_camera;
  // The reduced camera system over all keyframes, factorised, grows with
  // them and their covisibility: applied implicitly instead (memory:
  // doc/benchmarks-history.md, "the global adjustment on an observation budget").
  AdjustmentOptions sampled = options;
  sampled.implicit_schur = true;
  const int removed =
      bundleAdjust(map, ids, {gauge}, sampled, ObservationScope::kAll, report, &selected);
  // The landmarks left out follow the keyframe that made them.
  for (int l : seen) {
    Landmark& landmark = map.landmarks[size_t(l)];
    if (!landmark.valid || selected.count(l)) continue;
    const auto it = before.find(landmark.reference_keyframe);
    if (it == before.end()) continue;
    landmark.p_in_world = map.keyframes[size_t(it->first)].world_from_camera *
                          (it->second.inverse() * landmark.p_in_world);
  }
  return removed;
}

std::map<int, Sim3d> optimisePoseGraph(const std::map<int, Sim3d>& nodes,
                                       const std::vector<PoseGraphEdge>& edges,
                                       const std::set<int>& fixed, int iterations, int threads) {
  struct Node {
    Eigen::Quaterniond q;
    Eigen::Vector3d t;
    double log_s;
  };
  std::map<int, Node> values;
  for (const auto& [k, s] : nodes) values[k] = Node{s.rotation, s.translation, std::log(s.scale)};
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::EigenQuaternionManifold quaternion_manifold;
  for (const PoseGraphEdge& e : edges) {
    Node& a = values.at(e.from);
    Node& b = values.at(e.to);
    problem.AddResidualBlock(Sim3EdgeResidual::Create(e.from_from_to, e.weight), nullptr,
                             a.q.coeffs().data(), a.t.data(), &a.log_s, b.q.coeffs().data(),
                             b.t.data(), &b.log_s);
  }
  for (auto& [k, v] : values) {
    if (!problem.HasParameterBlock(v.q.coeffs().data())) continue;
    problem.SetManifold(v.q.coeffs().data(), &quaternion_manifold);
    if (fixed.count(k)) {
      problem.SetParameterBlockConstant(v.q.coeffs().data());
      problem.SetParameterBlockConstant(v.t.data());
      problem.SetParameterBlockConstant(&v.log_s);
    }
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = iterations;
  solver.num_threads = threads;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  serialiseOpenMpInThisThread();  // CHOLMOD's teams of 4 (core/threads.h)
  ceres::Solve(solver, &problem, &summary);
  std::map<int, Sim3d> out;
  for (const auto& [k, v] : values) out[k] = Sim3d(std::exp(v.log_s), v.q.normalized(), v.t);
  return out;
}

}  // namespace lookboth::vo
