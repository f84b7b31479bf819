// Private: the residuals of stage `joint` (joint_adjustment.h), in a header
// of their own so that tests can compare them (tests/joint_costs_test.cpp).
// Only the files that build the costs include it: it instantiates the
// camera models with Jets, half a minute of compile time per file.
#pragma once
#include <ceres/ceres.h>
#include <ceres/evaluation_callback.h>

#include <array>
#include <type_traits>
#include <variant>
#include <vector>

#include "joint_bracket.h"
#include "lookboth/cameras/camera.h"
#include "lookboth/geometry/trajectory.h"
#include "pose_costs.h"

namespace lookboth::joint_detail {

// poseAt at tau = tau_camera - offset for a cost whose Jets are long: the
// interpolation is differentiated with Jets of its own 15 inputs (the two
// nodes and the offset) and chained into T, which halves the work.
template <typename T>
Rigid3<T> poseAtChained(const Bracket& b, const T* nk, const T* nk1, const T* offset,
                        double tau_camera) {
  if constexpr (std::is_same_v<T, double>) {
    return poseAt(b, nk, nk1, T(tau_camera) - offset[0]);
  } else {
    using J = ceres::Jet<double, 15>;
    J a[7], c[7];
    for (int i = 0; i < 7; ++i) {
      a[i] = J(nk[i].a, i);
      c[i] = J(nk1[i].a, 7 + i);
    }
    const J tau = J(tau_camera) - J(offset[0].a, 14);
    const Rigid3<J> w = poseAt(b, a, c, tau);
    auto chain = [&](const J& v) {
      T r;
      r.a = v.a;
      r.v = v.v[14] * offset[0].v;  // (d tau / d offset = -1 is in v.v[14])
      for (int i = 0; i < 7; ++i) r.v += v.v[i] * nk[i].v + v.v[7 + i] * nk1[i].v;
      return r;
    };
    return Rigid3<T>(Eigen::Quaternion<T>(chain(w.rotation.w()), chain(w.rotation.x()),
                                          chain(w.rotation.y()), chain(w.rotation.z())),
                     Eigen::Matrix<T, 3, 1>(chain(w.translation.x()), chain(w.translation.y()),
                                            chain(w.translation.z())));
  }
}

// Blocks: node k, node k+1 (7: [t q]), the edge's scale segment (1).
struct RelativeMotionCost {
  Rigid3d delta_unscaled;  // Nref_k^-1 Nref_k+1 in trajectory units
  double sigma_t = 1, sigma_r = 1;
  double vertical_ratio = 1, tilt_ratio = 1;  // body z's sigma / sigma_t; roll's, pitch's / sigma_r
  static ceres::CostFunction* Create(const Rigid3d& delta_unscaled, double sigma_t, double sigma_r,
                                     double vertical_ratio, double tilt_ratio) {
    auto* cost = new RelativeMotionCost;
    cost->delta_unscaled = delta_unscaled;
    cost->sigma_t = sigma_t;
    cost->sigma_r = sigma_r;
    cost->vertical_ratio = vertical_ratio;
    cost->tilt_ratio = tilt_ratio;
    return new ceres::AutoDiffCostFunction<RelativeMotionCost, 6, 7, 7, 1>(cost);
  }
  template <typename T>
  bool operator()(const T* nk, const T* nk1, const T* scale, T* residual) const {
    const Rigid3<T> a = poseFromParams(nk), b = poseFromParams(nk1);
    const Eigen::Matrix<T, 3, 1> dt = a.rotation.conjugate() * (b.translation - a.translation) -
                                      delta_unscaled.translation.cast<T>() * scale[0];
    const Eigen::Matrix<T, 3, 1> dr = so3Log(Eigen::Quaternion<T>(
        delta_unscaled.rotation.cast<T>().conjugate() * a.rotation.conjugate() * b.rotation));
    for (int i = 0; i < 3; ++i) {
      residual[i] = dt[i] / T(i == 2 ? sigma_t * vertical_ratio : sigma_t);
      residual[3 + i] = dr[i] / T(i < 2 ? sigma_r * tilt_ratio : sigma_r);
    }
    return true;
  }
};

// Blocks: three consecutive trajectory nodes (7, 7, 7), one at least added
// between the input's samples: the change of the mean velocity (world) and
// angular rate (body) across the middle node, whose sigma a white-noise
// acceleration gives (the velocity and the rate random walks).
struct SmoothMotionCost {
  double h0 = 1, h1 = 1;            // the two intervals [s]
  double sigma_v = 1, sigma_w = 1;  // [m/s], [rad/s]
  static ceres::CostFunction* Create(double h0, double h1, double sigma_v, double sigma_w) {
    auto* cost = new SmoothMotionCost;
    cost->h0 = h0;
    cost->h1 = h1;
    cost->sigma_v = sigma_v;
    cost->sigma_w = sigma_w;
    return new ceres::AutoDiffCostFunction<SmoothMotionCost, 6, 7, 7, 7>(cost);
  }
  template <typename T>
  bool operator()(const T* n0, const T* n1, const T* n2, T* residual) const {
    const Rigid3<T> a = poseFromParams(n0), b = poseFromParams(n1), c = poseFromParams(n2);
    const Eigen::Matrix<T, 3, 1> dv =
        (c.translation - b.translation) / T(h1) - (b.translation - a.translation) / T(h0);
    const Eigen::Matrix<T, 3, 1> dw =
        so3Log(Eigen::Quaternion<T>(b.rotation.conjugate() * c.rotation)) / T(h1) -
        so3Log(Eigen::Quaternion<T>(a.rotation.conjugate() * b.rotation)) / T(h0);
    for (int i = 0; i < 3; ++i) {
      residual[i] = dv[i] / T(sigma_v);
      residual[3 + i] = dw[i] / T(sigma_w);
    }
    return true;
  }
};

// Blocks: two neighbouring scale segments (1, 1).
struct ScaleWalkCost {
  double sigma = 1;
  static ceres::CostFunction* Create(double sigma) {
    auto* cost = new ScaleWalkCost;
    cost->sigma = sigma;
    return new ceres::AutoDiffCostFunction<ScaleWalkCost, 1, 1, 1>(cost);
  }
  template <typename T>
  bool operator()(const T* a, const T* b, T* residual) const {
    residual[0] = (b[0] - a[0]) / T(sigma);
    return true;
  }
};

// Blocks: a scalar (1): a scale, a clock offset.
struct ScalarPriorCost {
  double value = 0, sigma = 1;
  static ceres::CostFunction* Create(double value, double sigma) {
    auto* cost = new ScalarPriorCost;
    cost->value = value;
    cost->sigma = sigma;
    return new ceres::AutoDiffCostFunction<ScalarPriorCost, 1, 1>(cost);
  }
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    residual[0] = (x[0] - T(value)) / T(sigma);
    return true;
  }
};

// One tangent component c of a pose ([dt; dtheta] at `prior`). Blocks: the pose (7).
struct ComponentPriorCost {
  Rigid3d prior;
  int component = 0;
  double sigma = 1;
  static ceres::CostFunction* Create(const Rigid3d& prior, int component, double sigma) {
    auto* cost = new ComponentPriorCost;
    cost->prior = prior;
    cost->component = component;
    cost->sigma = sigma;
    return new ceres::AutoDiffCostFunction<ComponentPriorCost, 1, 7>(cost);
  }
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    const Eigen::Matrix<T, 6, 1> e = poseError(poseFromParams(x), prior);
    residual[0] = e[component] / T(sigma);
    return true;
  }
};

// A camera's pose held near a registration on record: the pose error
// [dt; dtheta] whitened by the record's covariance. Blocks: the pose (7).
struct PosePriorCost {
  Rigid3d prior;
  Matrix6d sqrt_info;
  static ceres::CostFunction* Create(const Rigid3d& prior, const Matrix6d& sqrt_info) {
    auto* cost = new PosePriorCost;
    cost->prior = prior;
    cost->sqrt_info = sqrt_info;
    return new ceres::AutoDiffCostFunction<PosePriorCost, 6, 7>(cost);
  }
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    const Eigen::Matrix<T, 6, 1> e = poseError(poseFromParams(x), prior);
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_info.cast<T>() * e;
    return true;
  }
};

struct MarkerPoseCost {
  Bracket bracket;
  double tau_camera_s = 0;  // t_camera - t_k [s]
  Rigid3d measured;         // camera_from_marker
  Matrix6d sqrt_info;
  template <typename T>
  bool operator()(const T* nk, const T* nk1, const T* x, const T* camera, const T* offset,
                  T* residual) const {
    const Rigid3<T> world_from_marker =
        poseAtChained(bracket, nk, nk1, offset, tau_camera_s) * poseFromParams(x);
    const Rigid3<T> predicted = poseFromParams(camera).inverse() * world_from_marker;
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_info.cast<T>() * poseError(predicted, measured);
    return true;
  }
};

template <typename T>
bool projectWith(const Camera& camera, const Eigen::Matrix<T, 3, 1>& p, T* pixel) {
  std::array<T, kMaxParams> params;
  const std::vector<double>& values = camera.params();
  for (std::size_t i = 0; i < values.size() && i < kMaxParams; ++i) params[i] = T(values[i]);
  return std::visit(
      [&](const auto& model) { return model.project(params.data(), p.data(), pixel); },
      camera.model());
}

// The camera model's projection of a point whose derivatives are of any
// length: the model is differentiated only with respect to the point (a
// Jet of 3) and chained, so its cost does not grow with the cost's parameters.
template <typename T>
bool projectChained(const Camera& camera, const Eigen::Matrix<T, 3, 1>& p, T* pixel) {
  if constexpr (std::is_same_v<T, double>) {
    return projectWith(camera, p, pixel);
  } else {
    using J3 = ceres::Jet<double, 3>;
    const Eigen::Matrix<J3, 3, 1> q(J3(p[0].a, 0), J3(p[1].a, 1), J3(p[2].a, 2));
    J3 out[2];
    if (!projectWith(camera, q, out)) return false;
    for (int r = 0; r < 2; ++r) {
      pixel[r].a = out[r].a;
      pixel[r].v = out[r].v[0] * p[0].v + out[r].v[1] * p[1].v + out[r].v[2] * p[2].v;
    }
    return true;
  }
}

// The pixel of a point and its 2x3 derivative with respect to the point
// (the model differentiated with Jets of 3).
inline bool projectWithJacobian(const Camera& camera, const Eigen::Vector3d& p,
                                Eigen::Vector2d* pixel, Eigen::Matrix<double, 2, 3>* d_pixel) {
  using J3 = ceres::Jet<double, 3>;
  const Eigen::Matrix<J3, 3, 1> q(J3(p[0], 0), J3(p[1], 1), J3(p[2], 2));
  J3 out[2];
  if (!projectWith(camera, q, out)) return false;
  for (int r = 0; r < 2; ++r) {
    (*pixel)[r] = out[r].a;
    d_pixel->row(r) = out[r].v.transpose();
  }
  return true;
}

// The analytic costs below differentiate with respect to each pose block's
// tangent [dt; dtheta] (the manifold of pose_costs.h: t + dt, R Exp(dtheta)),
// then give Ceres a Jacobian with respect to the 7 stored numbers whose
// product with the manifold's PlusJacobian is that tangent Jacobian, which
// is all Ceres uses: for the quaternion, d q/d theta = 1/2 q (x) [theta; 0]
// has orthogonal columns of norm 1/2, so its pseudo-inverse is 4x its
// transpose. (Tests compare the products with the autodiff costs.)
template <int R>
void liftPoseJacobian(const Eigen::Matrix<double, R, 6>& tangent, const Eigen::Quaterniond& q,
                      double* out) {
  Eigen::Map<Eigen::Matrix<double, R, 7, Eigen::RowMajor>> j(out);
  j.template leftCols<3>() = tangent.template leftCols<3>();
  j.template rightCols<4>().setZero();
  for (int i = 0; i < 3; ++i) {
    Eigen::Quaterniond e(0, 0, 0, 0);
    e.vec()[i] = 1;
    const Eigen::Vector4d c = (q * e).coeffs();
    j.template rightCols<4>() += 2.0 * tangent.col(3 + i) * c.transpose();
  }
}

// The derivative of poseAt with respect to the tangents [dt; dtheta] of the
// two nodes (columns 0-5 and 6-11) and to tau (column 12), rows the pose's
// tangent [dt (world); dtheta (body)], written out (it was Jets of 15, most
// of the joint's Jacobian time). With ck = N_k Nref_k^-1 (rotation R_k),
// w = Log(R_k^T R_k+1) and alpha = tau / duration (held in [0, 1]):
// correction = (R_k Exp(alpha w), t_k + alpha (t_k+1 - t_k)); a node's
// rotation perturbation moves w through the inverse right Jacobian of Log,
// and Exp(alpha w) through the right Jacobian of Exp.
using PoseAtJacobian = Eigen::Matrix<double, 6, 13>;

inline Rigid3d poseAtWithJacobian(const Bracket& b, const double* nk, const double* nk1, double tau,
                                  PoseAtJacobian* d) {
  const Rigid3d n_k = poseFromParams(nk), n_k1 = poseFromParams(nk1);
  const Rigid3d ck = n_k * b.ref_inverse_k, ck1 = n_k1 * b.ref_inverse_k1;
  double alpha = tau / b.duration_s, d_alpha = 1.0 / b.duration_s;
  if (alpha < 0 || alpha > 1) {  // held at the nearer node: tau does not move it
    alpha = alpha < 0 ? 0 : 1;
    d_alpha = 0;
  }
  const Eigen::Quaterniond q_rel = ck.rotation.conjugate() * ck1.rotation;
  const Eigen::Vector3d w = so3Log(q_rel);
  const Eigen::Vector3d wa = w * alpha;
  const Eigen::Quaterniond e = so3Exp(wa);
  const Rigid3d correction(ck.rotation * e,
                           ck.translation + (ck1.translation - ck.translation) * alpha);
  const double delta = tau - b.tau_ref_s;
  const Eigen::Vector3d wd = b.omega_body * delta;
  const Rigid3d reference(b.reference.rotation * so3Exp(wd),
                          b.reference.translation + b.velocity_world * delta);
  const Rigid3d pose = correction * reference;

  // A perturbation phi_c of the correction's rotation (on the right) moves
  // the pose by [-R_c [t_r]x phi_c; R_r^T phi_c].
  const Eigen::Matrix3d rc = correction.rotation.toRotationMatrix();
  const Eigen::Matrix3d rr_t = reference.rotation.toRotationMatrix().transpose();
  const Eigen::Matrix3d to_translation = -rc * skew(reference.translation);
  // phi_c from the nodes' rotations (phi_k = R_ik^T dtheta_k, right perturbations of R_k):
  // phi_c = (Exp(alpha w)^T - m R_rel^T) phi_k + m phi_k+1, m = alpha Jr(alpha w) Jr^-1(w).
  const Eigen::Matrix3d m =
      alpha * so3LeftJacobian<double>(-wa) * so3LeftJacobianInverse<double>(Eigen::Vector3d(-w));
  const Eigen::Matrix3d a_k =
      (e.toRotationMatrix().transpose() - m * q_rel.toRotationMatrix().transpose()) *
      b.ref_inverse_k.rotation.toRotationMatrix().transpose();
  const Eigen::Matrix3d a_k1 = m * b.ref_inverse_k1.rotation.toRotationMatrix().transpose();
  d->setZero();
  const auto node = [&](int col, double weight, const Rigid3d& n, const Rigid3d& ref_inverse,
                        const Eigen::Matrix3d& a) {
    d->block<3, 3>(0, col) = weight * Eigen::Matrix3d::Identity();
    d->block<3, 3>(0, col + 3) =
        to_translation * a - weight * n.rotation.toRotationMatrix() * skew(ref_inverse.translation);
    d->block<3, 3>(3, col + 3) = rr_t * a;
  };
  node(0, 1 - alpha, n_k, b.ref_inverse_k, a_k);
  node(6, alpha, n_k1, b.ref_inverse_k1, a_k1);
  // tau: alpha moves the correction by (w, t_k+1 - t_k) d_alpha, and the
  // reference by (omega, v).
  d->block<3, 1>(0, 12) =
      (to_translation * w + (ck1.translation - ck.translation)) * d_alpha + rc * b.velocity_world;
  d->block<3, 1>(3, 12) = rr_t * w * d_alpha + b.omega_body;
  return pose;
}

// Spreads a cost's Jacobian with respect to world_from_fisheye (tangent,
// R x 6) onto the blocks node_k, node_k+1 (stored numbers, lifted as above)
// and, when given, the clock offset (tau = t_camera - offset).
template <int R>
void chainFisheyeJacobian(const Eigen::Matrix<double, R, 6>& d_fisheye, const PoseAtJacobian& d,
                          const double* nk, const double* nk1, double* node_k, double* node_k1,
                          double* offset) {
  if (node_k != nullptr) {
    const Eigen::Matrix<double, R, 6> t = d_fisheye * d.middleCols<6>(0);
    liftPoseJacobian<R>(t, Eigen::Quaterniond(nk[6], nk[3], nk[4], nk[5]), node_k);
  }
  if (node_k1 != nullptr) {
    const Eigen::Matrix<double, R, 6> t = d_fisheye * d.middleCols<6>(6);
    liftPoseJacobian<R>(t, Eigen::Quaterniond(nk1[6], nk1[3], nk1[4], nk1[5]), node_k1);
  }
  if (offset != nullptr) {
    Eigen::Map<Eigen::Matrix<double, R, 1>> out(offset);
    out = -(d_fisheye * d.col(12));
  }
}

struct MarkerCornersCost {
  Bracket bracket;
  double tau_camera_s = 0;
  const Camera* camera_model = nullptr;
  std::array<Eigen::Vector3d, 4> corners_in_marker;
  std::array<Eigen::Vector2d, 4> observed;
  double sigma_px = 1;
  template <typename T>
  bool operator()(const T* nk, const T* nk1, const T* x, const T* camera, const T* offset,
                  T* residual) const {
    const T tau = T(tau_camera_s) - offset[0];
    const Rigid3<T> camera_from_marker =
        poseFromParams(camera).inverse() * poseAt(bracket, nk, nk1, tau) * poseFromParams(x);
    for (int c = 0; c < 4; ++c) {
      const Eigen::Matrix<T, 3, 1> p = camera_from_marker * corners_in_marker[c].cast<T>();
      if (p.z() <= T(0)) return false;
      T pixel[2];
      if (!projectChained(*camera_model, p, pixel)) return false;
      residual[2 * c] = (T(observed[c].x()) - pixel[0]) / T(sigma_px);
      residual[2 * c + 1] = (T(observed[c].y()) - pixel[1]) / T(sigma_px);
    }
    return true;
  }
};

// What both analytic marker costs need at a point where Jacobians are
// asked for: the poses of parameters [node_k, node_k+1, fisheye_from_marker,
// world_from_camera, offset], their rotations, and the fisheye pose's
// derivative; then writeJacobians() lifts and chains their tangent ones.
struct MarkerPoint {
  MarkerPoint(const Bracket& bracket, double tau_camera_s, double const* const* parameters)
      : nk(parameters[0]),
        nk1(parameters[1]),
        fisheye(poseAtWithJacobian(bracket, parameters[0], parameters[1],
                                   tau_camera_s - parameters[4][0], &d_fisheye)),
        x(poseFromParams(parameters[2])),
        camera(poseFromParams(parameters[3])),
        rc_t(camera.rotation.toRotationMatrix().transpose()),
        rf(fisheye.rotation.toRotationMatrix()),
        rx(x.rotation.toRotationMatrix()) {}
  template <int R>
  void writeJacobians(const Eigen::Matrix<double, R, 6>& d_fisheye_tangent,
                      const Eigen::Matrix<double, R, 6>& d_x,
                      const Eigen::Matrix<double, R, 6>& d_camera, double** jacobians) const {
    if (jacobians[2] != nullptr) liftPoseJacobian<R>(d_x, x.rotation, jacobians[2]);
    if (jacobians[3] != nullptr) liftPoseJacobian<R>(d_camera, camera.rotation, jacobians[3]);
    chainFisheyeJacobian<R>(d_fisheye_tangent, d_fisheye, nk, nk1, jacobians[0], jacobians[1],
                            jacobians[4]);
  }
  const double* nk;
  const double* nk1;
  PoseAtJacobian d_fisheye;      // (declared before `fisheye`: set with it)
  Rigid3d fisheye, x, camera;    // world_from_fisheye, fisheye_from_marker, world_from_camera
  Eigen::Matrix3d rc_t, rf, rx;  // R_camera^T, R_fisheye, R_x
};

// MarkerPoseCost with the derivatives written out (the stage's; the
// autodiff struct is the tests' reference). Blocks: node_k, node_k+1,
// fisheye_from_marker, world_from_camera, the camera's clock offset.
class AnalyticMarkerPoseCost : public ceres::SizedCostFunction<6, 7, 7, 7, 7, 1> {
 public:
  explicit AnalyticMarkerPoseCost(const MarkerPoseCost& c) : c_(c) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    if (jacobians == nullptr) {
      return c_(parameters[0], parameters[1], parameters[2], parameters[3], parameters[4],
                residuals);
    }
    const MarkerPoint m(c_.bracket, c_.tau_camera_s, parameters);
    // predicted camera_from_marker = C^-1 F X
    const Eigen::Vector3d t_p =
        m.rc_t * (m.rf * m.x.translation + m.fisheye.translation - m.camera.translation);
    const Eigen::Quaterniond q_p =
        m.camera.rotation.conjugate() * m.fisheye.rotation * m.x.rotation;
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = t_p - c_.measured.translation;
    e.tail<3>() = so3Log(Eigen::Quaterniond(c_.measured.rotation.conjugate() * q_p));
    Eigen::Map<Eigen::Matrix<double, 6, 1>> r(residuals);
    r = c_.sqrt_info * e;
    // Tangent derivatives of e; the rotation error's through Jr^-1(e_r).
    const Eigen::Matrix3d jr_inv = so3LeftJacobianInverse<double>(-e.tail<3>());
    const Eigen::Matrix3d rp_t = q_p.toRotationMatrix().transpose();
    Matrix6d d_c = Matrix6d::Zero(), d_f = Matrix6d::Zero(), d_x = Matrix6d::Zero();
    d_c.block<3, 3>(0, 0) = -m.rc_t;
    d_c.block<3, 3>(0, 3) = skew(t_p);
    d_c.block<3, 3>(3, 3) = -jr_inv * rp_t;
    d_f.block<3, 3>(0, 0) = m.rc_t;
    d_f.block<3, 3>(0, 3) = -m.rc_t * m.rf * skew(m.x.translation);
    d_f.block<3, 3>(3, 3) = jr_inv * m.rx.transpose();
    d_x.block<3, 3>(0, 0) = m.rc_t * m.rf;
    d_x.block<3, 3>(3, 3) = jr_inv;
    m.writeJacobians<6>(c_.sqrt_info * d_f, c_.sqrt_info * d_x, c_.sqrt_info * d_c, jacobians);
    return true;
  }

 private:
  MarkerPoseCost c_;
};

// MarkerCornersCost with the derivatives written out (blocks as above).
class AnalyticMarkerCornersCost : public ceres::SizedCostFunction<8, 7, 7, 7, 7, 1> {
 public:
  explicit AnalyticMarkerCornersCost(const MarkerCornersCost& c) : c_(c) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    if (jacobians == nullptr) {
      return c_(parameters[0], parameters[1], parameters[2], parameters[3], parameters[4],
                residuals);
    }
    const MarkerPoint m(c_.bracket, c_.tau_camera_s, parameters);
    Eigen::Matrix<double, 8, 6> d_c, d_f, d_x;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d q = m.rx * c_.corners_in_marker[k] + m.x.translation;  // in the fisheye
      const Eigen::Vector3d p = m.rc_t * (m.rf * q + m.fisheye.translation - m.camera.translation);
      if (p.z() <= 0) return false;
      Eigen::Vector2d pixel;
      Eigen::Matrix<double, 2, 3> d_pixel;
      if (!projectWithJacobian(*c_.camera_model, p, &pixel, &d_pixel)) return false;
      residuals[2 * k] = (c_.observed[k].x() - pixel.x()) / c_.sigma_px;
      residuals[2 * k + 1] = (c_.observed[k].y() - pixel.y()) / c_.sigma_px;
      const Eigen::Matrix<double, 2, 3> d_p = -d_pixel / c_.sigma_px;
      d_c.block<2, 3>(2 * k, 0) = d_p * -m.rc_t;
      d_c.block<2, 3>(2 * k, 3) = d_p * skew(p);
      d_f.block<2, 3>(2 * k, 0) = d_p * m.rc_t;
      d_f.block<2, 3>(2 * k, 3) = d_p * (-m.rc_t * m.rf * skew(q));
      d_x.block<2, 3>(2 * k, 0) = d_p * (m.rc_t * m.rf);
      d_x.block<2, 3>(2 * k, 3) = d_p * (-m.rc_t * m.rf * m.rx * skew(c_.corners_in_marker[k]));
    }
    m.writeJacobians<8>(d_f, d_x, d_c, jacobians);
    return true;
  }

 private:
  MarkerCornersCost c_;
};

// A blob's residual written directly, all in Jets: the stage uses
// CachedBlobCost below, and tests/joint_costs_test.cpp checks that the two agree.
struct BlobCost {
  Bracket bracket;  // tau_ref_s = the frame's time, zero velocity
  const Camera* fisheye = nullptr;
  Eigen::Vector3d offset_in_camera = Eigen::Vector3d::Zero();
  Eigen::Vector2d observed;
  double sigma_px = 1;
  template <typename T>
  bool operator()(const T* nk, const T* nk1, const T* camera, T* residual) const {
    const Rigid3<T> world_from_fisheye = poseAt(bracket, nk, nk1, T(bracket.tau_ref_s));
    const Rigid3<T> world_from_camera = poseFromParams(camera);
    const Eigen::Matrix<T, 3, 1> p =
        world_from_fisheye.inverse() * (world_from_camera * offset_in_camera.cast<T>());
    T pixel[2];
    if (!projectChained(*fisheye, p, pixel)) return false;
    residual[0] = (T(observed.x()) - pixel[0]) / T(sigma_px);
    residual[1] = (T(observed.y()) - pixel[1]) / T(sigma_px);
    return true;
  }
};

// The poses world_from_fisheye of the blob frames and their derivatives with
// respect to the two nodes around each frame, computed once per evaluation
// point for all the blobs of a frame (a Ceres EvaluationCallback), instead of
// once per blob residual: BlobCost's interpolation with Jets of 21 was most of
// the joint's Jacobian time.
class FramePoseCache : public ceres::EvaluationCallback {
 public:
  using Jacobian = PoseAtJacobian;  // d pose / d [node_k node_k+1] (tangents; tau's unused)

  /// A frame between the nodes `node_k` and `node_k1` (parameter blocks that
  /// outlive the cache); returns its slot.
  std::size_t add(const Bracket& bracket, const double* node_k, const double* node_k1) {
    slots_.push_back({bracket, node_k, node_k1});
    poses_.emplace_back();
    jacobians_.emplace_back();
    have_values_ = have_jacobians_ = false;
    return slots_.size() - 1;
  }

  void PrepareForEvaluation(bool evaluate_jacobians, bool new_evaluation_point) override {
    if (new_evaluation_point) have_values_ = have_jacobians_ = false;
    if (evaluate_jacobians ? have_jacobians_ : have_values_) return;
    for (std::size_t i = 0; i < slots_.size(); ++i) compute(i, evaluate_jacobians);
    have_values_ = true;
    have_jacobians_ = have_jacobians_ || evaluate_jacobians;
  }

  /// [tx ty tz qx qy qz qw] of a slot at the last prepared point.
  const std::array<double, 7>& pose(std::size_t slot) const { return poses_[slot]; }
  const Jacobian& jacobian(std::size_t slot) const { return jacobians_[slot]; }

 private:
  struct Slot {
    Bracket bracket;
    const double* node_k;
    const double* node_k1;
  };
  void compute(std::size_t i, bool with_jacobian) {
    const Slot& s = slots_[i];
    if (!with_jacobian) {
      const Rigid3d w = poseAt<double>(s.bracket, s.node_k, s.node_k1, s.bracket.tau_ref_s);
      for (int r = 0; r < 3; ++r) poses_[i][r] = w.translation[r];
      for (int r = 0; r < 4; ++r) poses_[i][3 + r] = w.rotation.coeffs()[r];
      return;
    }
    const Rigid3d w =
        poseAtWithJacobian(s.bracket, s.node_k, s.node_k1, s.bracket.tau_ref_s, &jacobians_[i]);
    for (int r = 0; r < 3; ++r) poses_[i][r] = w.translation[r];
    for (int r = 0; r < 4; ++r) poses_[i][3 + r] = w.rotation.coeffs()[r];
  }
  std::vector<Slot> slots_;
  std::vector<std::array<double, 7>> poses_;
  std::vector<Jacobian> jacobians_;
  bool have_values_ = false, have_jacobians_ = false;
};

// BlobCost through a FramePoseCache: the same residual, with the derivatives
// written out and those with respect to the nodes chained from the cached
// frame-pose derivative.
// Its parameter blocks must be the slot's two nodes, then the camera.
class CachedBlobCost : public ceres::SizedCostFunction<2, 7, 7, 7> {
 public:
  CachedBlobCost(const FramePoseCache* cache, std::size_t slot, const Camera* fisheye,
                 const Eigen::Vector3d& offset_in_camera, const Eigen::Vector2d& observed,
                 double sigma_px)
      : cache_(cache),
        slot_(slot),
        fisheye_(fisheye),
        offset_in_camera_(offset_in_camera),
        observed_(observed),
        sigma_px_(sigma_px) {}

  template <typename T>
  bool residualOf(const T* world_from_fisheye_params, const T* camera, T* residual) const {
    const Rigid3<T> world_from_fisheye = poseFromParams(world_from_fisheye_params);
    const Eigen::Matrix<T, 3, 1> p =
        world_from_fisheye.inverse() * (poseFromParams(camera) * offset_in_camera_.cast<T>());
    T pixel[2];
    if (!projectChained(*fisheye_, p, pixel)) return false;
    residual[0] = (T(observed_.x()) - pixel[0]) / T(sigma_px_);
    residual[1] = (T(observed_.y()) - pixel[1]) / T(sigma_px_);
    return true;
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const std::array<double, 7>& f = cache_->pose(slot_);
    const double* camera = parameters[2];
    if (jacobians == nullptr) return residualOf(f.data(), camera, residuals);
    // p = R_f^T (R_c o + t_c - t_f); tangent derivatives, then lifted and
    // chained through the cached frame pose's derivative.
    const Rigid3d F = poseFromParams(f.data()), C = poseFromParams(camera);
    const Eigen::Matrix3d rf_t = F.rotation.toRotationMatrix().transpose();
    const Eigen::Matrix3d rc = C.rotation.toRotationMatrix();
    const Eigen::Vector3d p = rf_t * (rc * offset_in_camera_ + C.translation - F.translation);
    Eigen::Vector2d pixel;
    Eigen::Matrix<double, 2, 3> d_pixel;
    if (!projectWithJacobian(*fisheye_, p, &pixel, &d_pixel)) return false;
    residuals[0] = (observed_.x() - pixel.x()) / sigma_px_;
    residuals[1] = (observed_.y() - pixel.y()) / sigma_px_;
    const Eigen::Matrix<double, 2, 3> d_p = -d_pixel / sigma_px_;
    Eigen::Matrix<double, 2, 6> d_f, d_c;
    d_f.leftCols<3>() = d_p * -rf_t;
    d_f.rightCols<3>() = d_p * skew(p);
    d_c.leftCols<3>() = d_p * rf_t;
    d_c.rightCols<3>() = d_p * (-rf_t * rc * skew(offset_in_camera_));
    if (jacobians[2] != nullptr) liftPoseJacobian<2>(d_c, C.rotation, jacobians[2]);
    if (jacobians[0] != nullptr || jacobians[1] != nullptr) {
      chainFisheyeJacobian<2>(d_f, cache_->jacobian(slot_), parameters[0], parameters[1],
                              jacobians[0], jacobians[1], nullptr);
    }
    return true;
  }

 private:
  const FramePoseCache* cache_;
  std::size_t slot_;
  const Camera* fisheye_;
  Eigen::Vector3d offset_in_camera_;
  Eigen::Vector2d observed_;
  double sigma_px_;
};

}  // namespace lookboth::joint_detail
