// Stage `motion_calibration` (paper eq. 1-2, after Zach & Taylor): the
// trajectory's metric scale s and fisheye_from_marker X from pairs of
// detections of the same camera. For detections i, j of one camera,
//   A = F_i^-1 F_j   (relative fisheye motion; translation scaled by s)
//   B = M_i^-1 M_j   (relative marker motion, M = camera_from_marker)
// satisfy A X = X B. Residual (in the fisheye frame F_i):
//   r = [t(A X) - t(X B); log(R(X B)^T R(A X))],
// whitened by the covariance of B propagated from the two detections'
// information matrices (plus the configured relative-motion noise of the
// trajectory), Huber loss; Ceres.
//
// Initialisation (linear, no hand-tuned start): the rotation axes of A and
// B give R0 with a = R0 b (Kabsch); the rotation about the mean axis n is
// left free: R_X = R_n(gamma) R0, and the translation equation
//   (R_A - I) t_X + s t_A - R_n(gamma) R0 t_B = 0
// is linear in (t_X, s) for a given gamma; gamma is found by a scan of the
// reduced 2x2 quadratic form.
//
// Observability: with planar robot motion all rotations of A are about the
// vertical, and the translation of X along that axis does not enter the
// equations. The information matrix J^T J over [dt (3); dtheta (3); ds]
// says which directions are determined; each undetermined one is fixed by a
// configured prior (prior_translation_m / prior_rotation_xyzw) and reported.
#include <Eigen/SVD>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

#include "lookboth/calib/motion_calibration.h"
#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "pose_costs.h"

namespace lookboth {
namespace {

using calib_detail::angleOf;
using calib_detail::sqrtInformation;

constexpr double kDeg = M_PI / 180.0;

struct MotionPair {
  Rigid3d a_unscaled;  ///< F_i^-1 F_j, trajectory units.
  Rigid3d b;           ///< M_i^-1 M_j.
  Rigid3d mi;          ///< M_i (its rotation maps the detections' noise into B).
  Matrix6d covariance_i, covariance_j;
  std::size_t i = 0, j = 0;  ///< Association indices.
  std::size_t camera = 0;    ///< Index of the camera that saw both.
};

Matrix6d detectionCovariance(const MarkerObservation& m, double default_t, double default_r) {
  Matrix6d cov = Matrix6d::Zero();
  if (m.information.isZero(0)) {
    cov.topLeftCorner<3, 3>().diagonal().setConstant(default_t * default_t);
    cov.bottomRightCorner<3, 3>().diagonal().setConstant(default_r * default_r);
    return cov;
  }
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(0.5 *
                                                    (m.information + m.information.transpose()));
  Eigen::Matrix<double, 6, 1> inv = eig.eigenvalues();
  for (int k = 0; k < 6; ++k) inv[k] = inv[k] > 1e-12 ? 1.0 / inv[k] : 1e12;
  return eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
}

// Covariance of B = M_i^-1 M_j (right perturbation) from those of M_i, M_j.
Matrix6d relativeCovariance(const Rigid3d& mi, const Rigid3d& b, const Matrix6d& cov_i,
                            const Matrix6d& cov_j) {
  Eigen::Matrix<double, 6, 12> J = Eigen::Matrix<double, 6, 12>::Zero();
  const Eigen::Matrix3d Ri_t = mi.rotation.toRotationMatrix().transpose();
  const Eigen::Matrix3d Rb_t = b.rotation.toRotationMatrix().transpose();
  J.block<3, 3>(0, 0) = -Ri_t;
  J.block<3, 3>(0, 3) = skew(Eigen::Vector3d(b.translation));
  J.block<3, 3>(0, 6) = Ri_t;
  J.block<3, 3>(3, 3) = -Rb_t;
  J.block<3, 3>(3, 9) = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 12, 12> C = Eigen::Matrix<double, 12, 12>::Zero();
  C.topLeftCorner<6, 6>() = cov_i;
  C.bottomRightCorner<6, 6>() = cov_j;
  return J * C * J.transpose();
}

struct MotionPairCost {
  MotionPairCost(const MotionPair& pair, const Matrix6d& sqrt_info)
      : a(pair.a_unscaled), b(pair.b), sqrt_info(sqrt_info) {}
  /// Parameter blocks: X = fisheye_from_marker [tx ty tz qx qy qz qw], the
  /// scale s; 6 residuals.
  static ceres::CostFunction* Create(const MotionPair& pair, const Matrix6d& sqrt_info) {
    return new ceres::AutoDiffCostFunction<MotionPairCost, 6, 7, 1>(
        new MotionPairCost(pair, sqrt_info));
  }
  template <typename T>
  bool operator()(const T* x, const T* s, T* residual) const {
    const Rigid3<T> X = poseFromParams(x);
    const Rigid3<T> A(a.rotation.cast<T>(), a.translation.cast<T>() * s[0]);
    const Rigid3<T> AX = A * X;
    const Rigid3<T> XB = X * b.cast<T>();
    Eigen::Matrix<T, 6, 1> e;
    e.template head<3>() = AX.translation - XB.translation;
    e.template tail<3>() = so3Log(Eigen::Quaternion<T>(XB.rotation.conjugate() * AX.rotation));
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_info.cast<T>() * e;
    return true;
  }
  Rigid3d a, b;
  Matrix6d sqrt_info;
};

// Prior along one direction v of the tangent space [dt; dtheta] of X.
struct DirectionPriorCost {
  /// Parameter block: X [tx ty tz qx qy qz qw]; 1 residual.
  static ceres::CostFunction* Create(const Rigid3d& prior, const Eigen::Vector3d& direction,
                                     bool translation, double sigma) {
    auto* cost = new DirectionPriorCost;
    cost->prior = prior;
    cost->direction = direction;
    cost->translation = translation;
    cost->sigma = sigma;
    return new ceres::AutoDiffCostFunction<DirectionPriorCost, 1, 7>(cost);
  }
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    const Rigid3<T> X = poseFromParams(x);
    T value = T(0);
    if (translation) {
      const Eigen::Matrix<T, 3, 1> d = X.translation - prior.translation.cast<T>();
      value = direction.cast<T>().dot(d);
    } else {
      const Eigen::Matrix<T, 3, 1> d =
          so3Log(Eigen::Quaternion<T>(prior.rotation.cast<T>().conjugate() * X.rotation));
      value = direction.cast<T>().dot(d);
    }
    residual[0] = value / T(sigma);
    return true;
  }
  Rigid3d prior;
  Eigen::Vector3d direction;
  bool translation = true;
  double sigma = 1;
};

Eigen::Matrix3d rotationAbout(const Eigen::Vector3d& n, double gamma) {
  return Eigen::AngleAxisd(gamma, n).toRotationMatrix();
}

// The linear initialisations' rows t_X = prior (with a prior translation),
// weighed against their metre-scale data rows: they decide only what the
// motion leaves undetermined. Without them a level floor's height of t_X
// came from the noise of the few rows that see it (`faults` seed 6: -3.0 m,
// and the mount's rotation 4.9 deg off after the nonlinear step).
constexpr double kPriorRowWeight = 0.1;

// Linear initialisation with the rotation known: (R_A - I) t_X [+ s t_A] = R t_B
// [- t_A in metric mode], least squares (minimum norm along what the motion
// leaves free; the nonlinear step's priors then fix those directions).
Rigid3d initialisationWithRotation(const std::vector<MotionPair>& pairs, bool scale_free,
                                   const Eigen::Quaterniond& rotation,
                                   const std::optional<Eigen::Vector3d>& prior_translation,
                                   double* scale) {
  const int ny = scale_free ? 4 : 3;
  const Eigen::Index data_rows = 3 * static_cast<Eigen::Index>(pairs.size());
  const Eigen::Index rows = data_rows + (prior_translation ? 3 : 0);
  Eigen::MatrixXd My = Eigen::MatrixXd::Zero(rows, ny);
  Eigen::VectorXd rhs(rows);
  if (prior_translation) {
    My.block(data_rows, 0, 3, 3) = kPriorRowWeight * Eigen::Matrix3d::Identity();
    rhs.tail<3>() = kPriorRowWeight * *prior_translation;
  }
  const Eigen::Matrix3d R = rotation.normalized().toRotationMatrix();
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const MotionPair& p = pairs[k];
    const Eigen::Index r = 3 * static_cast<Eigen::Index>(k);
    My.block(r, 0, 3, 3) = p.a_unscaled.rotation.toRotationMatrix() - Eigen::Matrix3d::Identity();
    if (scale_free) My.block(r, 3, 3, 1) = p.a_unscaled.translation;
    rhs.segment(r, 3) =
        R * p.b.translation -
        (scale_free ? Eigen::Vector3d::Zero() : Eigen::Vector3d(p.a_unscaled.translation));
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(My, Eigen::ComputeThinU | Eigen::ComputeThinV);
  svd.setThreshold(1e-6);
  const Eigen::VectorXd y = svd.solve(rhs);
  if (scale_free) {
    *scale = y[3];
    if (!(*scale > 0)) {
      throw Error("motion_calibration: the linear initialisation gives a non-positive scale (" +
                  formatDouble(*scale) +
                  "): the relative motions seen by the cameras are inconsistent");
    }
  }
  return Rigid3d(rotation.normalized(), y.head<3>());
}

// Linear initialisation. When the motion cannot determine the rotation (the
// robot never turned while seen), the configured prior rotation is the start;
// without one it throws.
Rigid3d linearInitialisation(const std::vector<MotionPair>& pairs, bool scale_free,
                             double min_rotation,
                             const std::optional<Eigen::Quaterniond>& prior_rotation,
                             const std::optional<Eigen::Vector3d>& prior_translation,
                             double* scale) {
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();  // sum w a b^T
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  int axis_pairs = 0;
  for (const MotionPair& p : pairs) {
    const Eigen::Vector3d wa = so3Log(p.a_unscaled.rotation.normalized());
    const Eigen::Vector3d wb = so3Log(p.b.rotation.normalized());
    if (wa.norm() < min_rotation || wb.norm() < min_rotation) continue;
    const double w = std::min(wa.norm(), wb.norm());
    const Eigen::Vector3d a = wa.normalized(), b = wb.normalized();
    cross += w * a * b.transpose();
    scatter += w * a * a.transpose();
    ++axis_pairs;
  }
  if (axis_pairs == 0) {
    if (prior_rotation)
      return initialisationWithRotation(pairs, scale_free, *prior_rotation, prior_translation,
                                        scale);
    throw Error(
        "motion_calibration: the robot never turned by more than min_rotation_for_axis_deg while "
        "a camera saw its marker: the rotation between fisheye and marker is not determined; "
        "drive a turn under a camera, or set prior_rotation_xyzw to the measured mount");
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  const Eigen::Matrix3d R0 = svd.matrixU() * d * svd.matrixV().transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> axes(scatter);
  const Eigen::Vector3d n = axes.eigenvectors().col(2);

  // Rows: (R_A - I) t_X [+ s t_A] - c v_perp - sn (n x v) = (n.v) n [- t_A in metric mode].
  const int ny = scale_free ? 4 : 3;
  const Eigen::Index data_rows = 3 * static_cast<Eigen::Index>(pairs.size());
  const Eigen::Index rows = data_rows + (prior_translation ? 3 : 0);
  Eigen::MatrixXd My = Eigen::MatrixXd::Zero(rows, ny), Mw = Eigen::MatrixXd::Zero(rows, 2);
  Eigen::VectorXd rhs(rows);
  if (prior_translation) {
    My.block(data_rows, 0, 3, 3) = kPriorRowWeight * Eigen::Matrix3d::Identity();
    rhs.tail<3>() = kPriorRowWeight * *prior_translation;
  }
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const MotionPair& p = pairs[k];
    const Eigen::Index r = 3 * static_cast<Eigen::Index>(k);
    const Eigen::Vector3d v = R0 * p.b.translation;
    const Eigen::Vector3d v_perp = v - n.dot(v) * n;
    My.block(r, 0, 3, 3) = p.a_unscaled.rotation.toRotationMatrix() - Eigen::Matrix3d::Identity();
    if (scale_free) My.block(r, 3, 3, 1) = p.a_unscaled.translation;
    Mw.block(r, 0, 3, 1) = -v_perp;
    Mw.block(r, 1, 3, 1) = -n.cross(v);
    rhs.segment(r, 3) = n.dot(v) * n - (scale_free ? Eigen::Vector3d::Zero()
                                                   : Eigen::Vector3d(p.a_unscaled.translation));
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd_y(My, Eigen::ComputeThinU | Eigen::ComputeThinV);
  svd_y.setThreshold(1e-6);
  auto project_out = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
    return x - My * svd_y.solve(x);
  };
  const Eigen::MatrixXd PMw = [&] {
    Eigen::MatrixXd m(rows, 2);
    m.col(0) = project_out(Mw.col(0));
    m.col(1) = project_out(Mw.col(1));
    return m;
  }();
  const Eigen::VectorXd Pb = project_out(rhs);
  const Eigen::Matrix2d Q = PMw.transpose() * PMw;
  const Eigen::Vector2d g = PMw.transpose() * Pb;
  auto cost = [&](double gamma) {
    const Eigen::Vector2d w(std::cos(gamma), std::sin(gamma));
    return w.dot(Q * w) - 2.0 * g.dot(w);
  };
  // The scale the least squares give at gamma (visual mode). Straight drives
  // fit gamma and gamma + pi almost equally well, the second with the scale's
  // sign flipped (a half turn about n reverses every in-plane motion): only
  // gammas with a positive scale are candidates.
  auto scaleAt = [&](double gamma) {
    const Eigen::Vector2d w(std::cos(gamma), std::sin(gamma));
    return svd_y.solve(rhs - Mw * w)[3];
  };
  auto admissible = [&](double gamma) { return !scale_free || scaleAt(gamma) > 0; };
  double best = 0, best_cost = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 720; ++k) {
    const double gamma = -M_PI + k * (2 * M_PI / 720);
    if (const double c = cost(gamma); c < best_cost && admissible(gamma)) {
      best_cost = c, best = gamma;
    }
  }
  if (!std::isfinite(best_cost)) {
    throw Error(
        "motion_calibration: the linear initialisation finds no rotation about the floor normal "
        "with a positive scale: the relative motions seen by the cameras are inconsistent");
  }
  double lo = best - M_PI / 360, hi = best + M_PI / 360;  // golden-section refinement
  for (int k = 0; k < 60; ++k) {
    const double m1 = lo + (hi - lo) * 0.381966, m2 = lo + (hi - lo) * 0.618034;
    if (cost(m1) < cost(m2)) {
      hi = m2;
    } else {
      lo = m1;
    }
  }
  const double gamma = 0.5 * (lo + hi);
  const Eigen::Vector2d w(std::cos(gamma), std::sin(gamma));
  const Eigen::VectorXd y = svd_y.solve(rhs - Mw * w);
  const Eigen::Matrix3d R = rotationAbout(n, gamma) * R0;
  if (scale_free) {
    *scale = y[3];
    if (!(*scale > 0)) {
      throw Error("motion_calibration: the linear initialisation gives a non-positive scale (" +
                  formatDouble(*scale) +
                  "): the relative motions seen by the cameras are inconsistent");
    }
  }
  return Rigid3d(Eigen::Quaterniond(R).normalized(), y.head<3>());
}

// Pairs that cannot be a rigid motion seen from two ends, whatever X and the
// scale are: a false detection (another marker, a reflection) or a detection
// stamped at the wrong time makes one. B = X^-1 A X, so
//  - B turns by the same angle as A: |angle(A) - angle(B)| must stay within
//    3 sigma of B's rotation noise + 1 deg;
//  - |t_B| = |(R_A - I) t_X + s t_A|: within |2 sin(angle/2)| |t_X| of
//    s |t_A|, with s the pairs' median ratio |t_B| / |t_A| (1 in metric
//    mode) and |t_X| bounded by `lever_m`; 3 sigma of B's translation noise +
//    10 % allowed.
// One wild pair weighs as much as hundreds in the linear initialisation's
// least squares (`faults` seed 6: the mount 54 deg off with the true
// trajectory). Returns how many pairs were set aside; keeps all of them when
// fewer than 3 would remain.
std::size_t screenPairs(std::vector<MotionPair>& pairs, bool scale_free, double lever_m) {
  auto rotationSigma = [](const MotionPair& p) {
    return std::sqrt(p.covariance_i.bottomRightCorner<3, 3>().trace() +
                     p.covariance_j.bottomRightCorner<3, 3>().trace());
  };
  auto translationSigma = [](const MotionPair& p) {
    return std::sqrt(p.covariance_i.topLeftCorner<3, 3>().trace() +
                     p.covariance_j.topLeftCorner<3, 3>().trace());
  };
  double s = 1.0;
  if (scale_free) {
    std::vector<double> ratios;
    for (const MotionPair& p : pairs) {
      const double ta = p.a_unscaled.translation.norm();
      if (ta > 1e-9) ratios.push_back(p.b.translation.norm() / ta);
    }
    if (ratios.empty()) return 0;
    std::nth_element(ratios.begin(), ratios.begin() + static_cast<long>(ratios.size() / 2),
                     ratios.end());
    s = ratios[ratios.size() / 2];
  }
  std::vector<MotionPair> kept;
  for (const MotionPair& p : pairs) {
    const double angle_a = calib_detail::angleOf(p.a_unscaled.rotation);
    const double angle_b = calib_detail::angleOf(p.b.rotation);
    if (std::abs(angle_a - angle_b) > 3 * rotationSigma(p) + kDeg) continue;
    const double tb = p.b.translation.norm();
    const double slack =
        2 * std::abs(std::sin(0.5 * angle_a)) * lever_m + 3 * translationSigma(p) + 0.1 * tb;
    if (std::abs(tb - s * p.a_unscaled.translation.norm()) > slack) continue;
    kept.push_back(p);
  }
  if (kept.size() < 3) return 0;
  const std::size_t removed = pairs.size() - kept.size();
  pairs = std::move(kept);
  return removed;
}

const char* componentName(int k) {
  static const char* names[6] = {"its offset along the fisheye's x axis",
                                 "its offset along the fisheye's y axis",
                                 "its offset along the fisheye's z axis (the height of the marker "
                                 "relative to the fisheye)",
                                 "its rotation about the marker's x axis",
                                 "its rotation about the marker's y axis",
                                 "its rotation about the marker's z axis"};
  return names[k];
}

struct Direction {
  Eigen::VectorXd v;  // tangent [dt; dtheta; (ds)]
  double eigenvalue = 0;
  double sigma = 0;
  enum Kind { kTranslation, kRotation, kScale } kind = kTranslation;
};

// The stage's steps in order, each a method: the pairs of detections, the
// linear start, two solves (the weights depend on R_X), what the motion
// determines, the priors for the rest, and the results.
class MotionCalibration {
 public:
  MotionCalibration(RegistrationProblem& problem, const MotionCalibrationOptions& options)
      : problem_(problem),
        options_(options),
        scale_free_(problem.input.mode == TrajectoryMode::kVisual) {}

  void run(const ProgressReporter& progress) {
    progress.report("motion_calibration", 0, 3);
    makePairs();
    initialise();
    progress.report("motion_calibration", 1, 3);
    progress.checkStop();
    // Two rounds: the whitening (and, with translation_from_camera_orientation,
    // t_B itself) depends on R_X. Iterating this to a fixed point is unstable
    // with noisy detections (measured on small_det: 0.2 m), so it stays at two.
    solve(false);
    progress.checkStop();
    information_ = solve(false);
    progress.report("motion_calibration", 2, 3);
    classifyDirections();
    describeObservability();
    writeResults();
    progress.report("motion_calibration", 3, 3);
  }

 private:
  /// Pairs of detections of one camera, min_pair_interval_s to
  /// max_pair_interval_s apart; the implausible ones screened out.
  void makePairs() {
    const TimeNs min_dt = static_cast<TimeNs>(options_.min_pair_interval_s * 1e9);
    const TimeNs max_dt = static_cast<TimeNs>(options_.max_pair_interval_s * 1e9);
    std::vector<Matrix6d> covariances(problem_.associations.size());
    const double default_t = 0.01, default_r = 2.0 * kDeg;
    for (std::size_t a = 0; a < problem_.associations.size(); ++a) {
      covariances[a] =
          detectionCovariance(problem_.marker(problem_.associations[a]), default_t, default_r);
    }
    for (const auto& [label, indices] : problem_.associations_by_camera) {
      detections_of_camera_.push_back(indices);
      std::size_t j = 0;
      for (std::size_t i = 0; i < indices.size(); ++i) {
        const Association& ai = problem_.associations[indices[i]];
        if (j <= i) j = i + 1;
        while (j < indices.size() &&
               problem_.associations[indices[j]].t_robot - ai.t_robot < min_dt) {
          ++j;
        }
        if (j >= indices.size()) break;
        const Association& aj = problem_.associations[indices[j]];
        if (aj.t_robot - ai.t_robot > max_dt) continue;
        MotionPair p;
        p.i = indices[i];
        p.j = indices[j];
        p.a_unscaled = ai.world_from_fisheye.inverse() * aj.world_from_fisheye;
        const Rigid3d& mi = problem_.marker(ai).camera_from_marker;
        p.b = mi.inverse() * problem_.marker(aj).camera_from_marker;
        p.mi = mi;
        p.camera = detections_of_camera_.size() - 1;
        p.covariance_i = covariances[p.i];
        p.covariance_j = covariances[p.j];
        pairs_.push_back(p);
      }
    }
    if (pairs_.size() < 3) {
      throw Error("motion_calibration: only " + std::to_string(pairs_.size()) +
                  " pairs of detections of one camera " +
                  formatDouble(options_.min_pair_interval_s) + " to " +
                  formatDouble(options_.max_pair_interval_s) +
                  " s apart: not enough to estimate the scale and fisheye_from_marker");
    }
    // The mount's lever for the screening: the prior's offset, else 0.5 m.
    const double lever_m =
        options_.prior_translation_m ? options_.prior_translation_m->norm() + 0.1 : 0.5;
    total_pairs_ = pairs_.size();
    screened_ = screenPairs(pairs_, scale_free_, lever_m);
  }

  void initialise() {
    X_ = linearInitialisation(pairs_, scale_free_, options_.min_rotation_for_axis_deg * kDeg,
                              options_.prior_rotation, options_.prior_translation_m, &scale_);
  }

  /// Each camera's orientation world_from_camera, averaged over its detections.
  std::vector<Eigen::Quaterniond> cameraRotations() const {
    std::vector<Eigen::Quaterniond> camera_rotation;
    for (const std::vector<std::size_t>& indices : detections_of_camera_) {
      std::vector<Eigen::Quaterniond> rotations;
      for (std::size_t a : indices) {
        const Association& as = problem_.associations[a];
        rotations.push_back(as.world_from_fisheye.rotation * X_.rotation *
                            problem_.marker(as).camera_from_marker.rotation.conjugate());
      }
      camera_rotation.push_back(calib_detail::meanRotation(rotations));
    }
    return camera_rotation;
  }

  /// With translation_from_camera_orientation: t_B from the marker's
  /// displacement in the camera frame, mapped by the marker's orientation
  /// PREDICTED from the camera's averaged orientation (the single
  /// detection's orientation carries its tilt noise into t_B); returns B's
  /// covariance for that t_B.
  Matrix6d useCameraOrientation(MotionPair& p, const Eigen::Quaterniond& camera_rotation) const {
    Matrix6d b_covariance = Matrix6d::Zero();
    const Association& ai = problem_.associations[p.i];
    const Eigen::Quaterniond camera_from_marker_rotation =
        camera_rotation.conjugate() * ai.world_from_fisheye.rotation * X_.rotation;
    const Eigen::Vector3d displacement =
        problem_.marker(problem_.associations[p.j]).camera_from_marker.translation -
        p.mi.translation;
    p.b.translation = camera_from_marker_rotation.conjugate() * displacement;
    const Eigen::Matrix3d R = camera_from_marker_rotation.toRotationMatrix();
    b_covariance.topLeftCorner<3, 3>() =
        R.transpose() *
        (p.covariance_i.topLeftCorner<3, 3>() + p.covariance_j.topLeftCorner<3, 3>()) * R;
    const Eigen::Matrix3d Rb_t = p.b.rotation.toRotationMatrix().transpose();
    b_covariance.bottomRightCorner<3, 3>() =
        p.covariance_j.bottomRightCorner<3, 3>() +
        Rb_t * p.covariance_i.bottomRightCorner<3, 3>() * Rb_t.transpose();
    return b_covariance;
  }

  /// One residual per pair, whitened with the weights of the current X.
  void addPairResiduals(ceres::Problem& ceres_problem) {
    const bool camera_orientation = options_.translation_from_camera_orientation;
    const double sigma_r = options_.sigma_rotation_deg * kDeg;
    const double sigma_t = options_.sigma_translation_m;
    const Eigen::Matrix3d Rx = X_.rotation.toRotationMatrix();
    std::vector<Eigen::Quaterniond> camera_rotation;
    if (camera_orientation) camera_rotation = cameraRotations();
    for (const MotionPair& measured : pairs_) {
      MotionPair p = measured;
      Matrix6d b_covariance_override = Matrix6d::Zero();
      if (camera_orientation)
        b_covariance_override = useCameraOrientation(p, camera_rotation[p.camera]);
      Matrix6d J = Matrix6d::Zero();
      J.topLeftCorner<3, 3>() = -Rx;
      J.bottomRightCorner<3, 3>() = -Eigen::Matrix3d::Identity();
      // Covariance of B at the PREDICTED relative motion X^-1 A X: weights
      // from the measured B would favour pairs whose noise shortened them
      // (a bias of the scale).
      const Rigid3d a_scaled(p.a_unscaled.rotation, scale_ * p.a_unscaled.translation);
      const Rigid3d b_predicted = X_.inverse() * a_scaled * X_;
      Matrix6d cov = J *
                     (camera_orientation
                          ? b_covariance_override
                          : relativeCovariance(p.mi, b_predicted, p.covariance_i, p.covariance_j)) *
                     J.transpose();
      cov.topLeftCorner<3, 3>().diagonal().array() += sigma_t * sigma_t;
      cov.bottomRightCorner<3, 3>().diagonal().array() += sigma_r * sigma_r;
      const Matrix6d sqrt_info = sqrtInformation(cov.inverse());
      ceres_problem.AddResidualBlock(MotionPairCost::Create(p, sqrt_info),
                                     new ceres::HuberLoss(options_.huber), x_, s_);
    }
  }

  /// The configured priors on the directions the motion leaves undetermined.
  void addPriors(ceres::Problem& ceres_problem) {
    for (const Direction& d : undetermined_) {
      if (d.kind == Direction::kScale) continue;
      const bool t = d.kind == Direction::kTranslation;
      if (t && !options_.prior_translation_m) continue;
      if (!t && !options_.prior_rotation) continue;
      const Rigid3d prior(options_.prior_rotation.value_or(X_.rotation),
                          options_.prior_translation_m.value_or(X_.translation));
      const Eigen::Vector3d direction = (t ? d.v.head<3>() : d.v.segment<3>(3)).normalized();
      const double sigma =
          t ? options_.prior_translation_sigma_m : options_.prior_rotation_sigma_deg * kDeg;
      ceres_problem.AddResidualBlock(DirectionPriorCost::Create(prior, direction, t, sigma),
                                     nullptr, x_);
    }
  }

  /// Builds and solves the problem with weights from the current X; returns
  /// the information matrix J^T J over the tangent space [dt; dtheta; (ds)]
  /// at the solution (robust weights included).
  Eigen::MatrixXd solve(bool with_priors) {
    poseToParams(X_, x_);
    s_[0] = scale_;
    ceres::Problem ceres_problem;
    addPairResiduals(ceres_problem);
    ceres_problem.SetManifold(x_, newPoseManifold());
    if (!scale_free_) {
      ceres_problem.SetParameterBlockConstant(s_);
    } else {
      ceres_problem.SetParameterLowerBound(s_, 0, 1e-9);
    }
    if (with_priors) addPriors(ceres_problem);
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_QR;
    solver.max_num_iterations = options_.max_iterations;
    // Converge fully (a start from a measured mount can be a degree off; the
    // default relative cost tolerance of 1e-6 would stop ~1e-5 rad short).
    solver.function_tolerance = 1e-12;
    solver.parameter_tolerance = 1e-12;
    solver.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &ceres_problem, &summary);
    X_ = paramsToPose(x_);
    scale_ = s_[0];
    ceres::CRSMatrix crs;
    ceres::Problem::EvaluateOptions eval;
    eval.parameter_blocks = {x_};
    if (scale_free_) eval.parameter_blocks.push_back(s_);
    ceres_problem.Evaluate(eval, nullptr, nullptr, nullptr, &crs);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
    for (int r = 0; r < crs.num_rows; ++r) {
      for (int k = crs.rows[r]; k < crs.rows[r + 1]; ++k) J(r, crs.cols[k]) = crs.values[k];
    }
    return Eigen::MatrixXd(J.transpose() * J);
  }

  /// The information's eigenvectors: scale, translation or rotation, and
  /// which the motion leaves undetermined. An undetermined scale is an error.
  void classifyDirections() {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(information_);
    for (Eigen::Index k = 0; k < eig.eigenvalues().size(); ++k) {
      const double lambda = eig.eigenvalues()[k];
      eigenvalues_.push_back(lambda);
      Direction d;
      d.v = eig.eigenvectors().col(k);
      d.eigenvalue = lambda;
      d.sigma = lambda > 0 ? 1.0 / std::sqrt(lambda) : std::numeric_limits<double>::infinity();
      const double t2 = d.v.head<3>().squaredNorm(), r2 = d.v.segment<3>(3).squaredNorm();
      const double s2 = scale_free_ ? d.v[6] * d.v[6] : 0.0;
      if (s2 >= t2 && s2 >= r2) {
        d.kind = Direction::kScale;
        if (d.sigma * 1.0 > 0.01 * scale_) undetermined_.push_back(d);  // 1 % of the scale
      } else if (t2 >= r2) {
        d.kind = Direction::kTranslation;
        if (d.sigma > options_.max_translation_sigma_m) undetermined_.push_back(d);
      } else {
        d.kind = Direction::kRotation;
        if (d.sigma > options_.max_rotation_sigma_deg * kDeg) undetermined_.push_back(d);
      }
    }
    for (const Direction& d : undetermined_) {
      if (d.kind == Direction::kScale) {
        throw Error(
            "motion_calibration: the detections do not determine the trajectory's scale (sigma " +
            formatDouble(d.sigma) + "): the robot must move while cameras see its marker");
      }
    }
  }

  /// One undetermined direction in the message ("mostly tz (sigma ...);"),
  /// and the prior that fixes it or the component left unfixed.
  void describeDirection(const Direction& d) {
    int dominant = 0;
    Eigen::Matrix<double, 6, 1> v = d.v.head<6>();
    v.cwiseAbs().maxCoeff(&dominant);
    for (int c = 0; c < 6; ++c) {
      if (std::abs(v[c]) > 0.3) determined_[c] = false;
    }
    // Beyond a metre (or 90 degrees) the motion says nothing at all: a
    // figure like 176911 m would only distract.
    const bool rotation = d.kind == Direction::kRotation;
    const double sigma = rotation ? d.sigma / kDeg : d.sigma;
    message_ << " mostly " << componentName(dominant) << " (sigma from the motion alone "
             << (!std::isfinite(sigma)         ? std::string("infinite")
                 : sigma > (rotation ? 90 : 1) ? std::string(rotation ? "over 90" : "over 1")
                                               : formatFixed(sigma, 3))
             << (rotation ? " deg)" : " m)");
    message_ << ";";
    const bool t = d.kind == Direction::kTranslation;
    if (t && options_.prior_translation_m) {
      prior_notes_.push_back(std::string(componentName(dominant)) +
                             " from the configured prior_translation_m [" +
                             formatDouble((*options_.prior_translation_m)[0]) + ", " +
                             formatDouble((*options_.prior_translation_m)[1]) + ", " +
                             formatDouble((*options_.prior_translation_m)[2]) + "] m, sigma " +
                             formatDouble(options_.prior_translation_sigma_m) + " m");
    } else if (!t && options_.prior_rotation) {
      prior_notes_.push_back(std::string(componentName(dominant)) +
                             " from the configured prior_rotation_xyzw, sigma " +
                             formatDouble(options_.prior_rotation_sigma_deg) + " deg");
    } else {
      unfixed_.push_back(componentName(dominant));
    }
  }

  /// The observability statement; solves again with the priors when some
  /// fix what the motion cannot; a warning when nothing fixes a direction.
  void describeObservability() {
    if (undetermined_.empty()) {
      message_ << "The robot's motion determines the scale and every component of "
                  "fisheye_from_marker; no prior was used.";
      return;
    }
    message_ << "The robot's motion does not determine " << undetermined_.size()
             << (undetermined_.size() == 1 ? " direction" : " directions")
             << " of fisheye_from_marker:";
    for (const Direction& d : undetermined_) describeDirection(d);
    message_ << " the robot drives on a (nearly) planar floor, so its rotations are all about "
                "the vertical and the motion cannot tell where the marker is along that axis.";
    if (!prior_notes_.empty()) {
      message_ << " Fixed by priors: ";
      for (std::size_t k = 0; k < prior_notes_.size(); ++k) {
        message_ << (k ? "; " : "") << prior_notes_[k];
      }
      message_ << ".";
      information_ = solve(true);
    }
    if (!unfixed_.empty()) {
      std::string text = "fisheye_from_marker: no prior configured for ";
      for (std::size_t k = 0; k < unfixed_.size(); ++k) text += (k ? ", " : "") + unfixed_[k];
      text +=
          ": its value comes from the linear initialisation and is arbitrary; every camera "
          "position shifts with it (set register.motion_calibration.prior_translation_m / "
          "prior_rotation_xyzw to the measured mount)";
      problem_.result.warnings.push_back(text);
      message_ << " NOT fixed (no prior configured): ";
      for (std::size_t k = 0; k < unfixed_.size(); ++k) {
        message_ << (k ? ", " : "") << unfixed_[k];
      }
      message_ << ".";
    }
  }

  /// The covariance over [dt; dtheta; ds] (a pseudo-inverse when something
  /// stayed free), the estimate and the statement into the problem.
  void writeResults() {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_final(information_);
    Eigen::VectorXd inv = eig_final.eigenvalues();
    const double largest = inv.maxCoeff();
    for (Eigen::Index k = 0; k < inv.size(); ++k) {
      inv[k] = inv[k] > 1e-12 * largest ? 1.0 / inv[k] : 0.0;
    }
    const Eigen::MatrixXd covariance =
        eig_final.eigenvectors() * inv.asDiagonal() * eig_final.eigenvectors().transpose();

    problem_.scale = scale_;
    problem_.fisheye_from_marker = X_;
    Registration& r = problem_.result;
    r.scale = scale_;
    r.scale_sigma = scale_free_ ? std::sqrt(std::max(0.0, covariance(6, 6))) : 0.0;
    r.fisheye_from_marker = X_;
    r.fisheye_from_marker_covariance = covariance.topLeftCorner<6, 6>();
    r.fisheye_from_marker_determined = determined_;
    r.fisheye_from_marker_prior.clear();
    for (std::size_t k = 0; k < prior_notes_.size(); ++k) {
      r.fisheye_from_marker_prior += (k ? "; " : "") + prior_notes_[k];
    }
    r.observability.message = message_.str() + " (" + std::to_string(pairs_.size()) +
                              " motion pairs; eigenvalues of the information matrix over [t (m), "
                              "theta (rad)" +
                              (scale_free_ ? ", scale" : "") + "])";
    if (screened_ > 0) {
      r.observability.message += " motion_calibration: " + std::to_string(screened_) + " of " +
                                 std::to_string(total_pairs_) +
                                 " pairs of detections set aside: their rotation or displacement "
                                 "cannot be the robot's motion seen by a camera (false or "
                                 "mistimed detections).";
    }
    r.observability.eigenvalues = eigenvalues_;
  }

  RegistrationProblem& problem_;
  const MotionCalibrationOptions& options_;
  const bool scale_free_;
  std::vector<MotionPair> pairs_;
  std::vector<std::vector<std::size_t>> detections_of_camera_;
  std::size_t total_pairs_ = 0, screened_ = 0;
  Rigid3d X_;  ///< fisheye_from_marker.
  double scale_ = 1.0;
  double x_[7] = {};  ///< X_ as Ceres' parameter block.
  double s_[1] = {1.0};
  Eigen::MatrixXd information_;
  std::vector<double> eigenvalues_;
  std::vector<Direction> undetermined_;
  std::array<bool, 6> determined_ = {true, true, true, true, true, true};
  std::vector<std::string> prior_notes_;
  std::vector<std::string> unfixed_;
  std::ostringstream message_;
};

}  // namespace

void runMotionCalibration(RegistrationProblem& problem, const MotionCalibrationOptions& options,
                          const ProgressReporter& progress) {
  if (!problem.associated) {
    throw Error("motion_calibration needs associated detections: put 'associate' before it");
  }
  MotionCalibration(problem, options).run(progress);
}

}  // namespace lookboth
