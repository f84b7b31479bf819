// Camera projection models: the maths, as small value types.
//
// Frames and units: points are in the camera frame (x right, y down, z along
// the optical axis, any length unit); pixels follow OpenCV (pixel (0,0) is the
// centre of the top-left pixel, u right, v down); bearings are unit vectors in
// the camera frame; angles are in radians.
//
// Every model is a struct with the same members:
//   kId, kName            identifier and the name used in files;
//   numParams()           length of the parameter vector;
//   paramNames()          names of the parameters, in order;
//   project<T>()          pixel of a point; templated so that Ceres Jets can be
//                         used for automatic differentiation;
//   unproject()           unit bearing of a pixel;
//   validate()            empty when the parameters are usable, else a message
//                         naming the offending parameter;
//   maxIncidenceAngle()   largest angle to the optical axis up to which the
//                         model is one-to-one and smooth (see `Camera`).
// `project` returns false only for points the model cannot map at all (behind
// a pinhole camera, at the centre of projection, ...); the field-of-view limit
// is applied by `Camera`. `unproject` returns false when the pixel maps to no
// ray (outside a double-sphere valid circle, no convergence...).
//
// Parameter vectors are plain arrays of `numParams()` values; `Camera` checks
// their length and finiteness before any model function is called.
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <type_traits>
#include <vector>

namespace lookboth {

enum class CameraModelId {
  kPinhole,
  kRadTan,
  kRationalPolynomial,
  kKannalaBrandt,
  kScaramuzza,
  kDoubleSphere,
  kEucm,
  kMei,
  kFov
};

namespace camera_models_detail {

/// The value of a scalar: the number itself for double, the `a` part of a
/// ceres::Jet (found without including Ceres).
inline double value(double x) { return x; }
template <typename JetT>
double value(const JetT& x) {
  return value(x.a);
}

/// Applies the pinhole intrinsics: pixel = (fx * x + cx, fy * y + cy).
template <typename T>
void applyIntrinsics(const T* params, const T& x, const T& y, T* pixel) {
  pixel[0] = params[0] * x + params[2];
  pixel[1] = params[1] * y + params[3];
}

/// OpenCV distortion of normalized coordinates (x, y) = (X/Z, Y/Z) with the
/// coefficients k1 k2 p1 p2 k3 [k4 k5 k6]; `rational` selects the 8-coefficient
/// form. Returns false when the rational denominator is not positive.
template <typename T>
bool distortOpenCv(const T* k, bool rational, const T& x, const T& y, T* xd, T* yd) {
  const T r2 = x * x + y * y;
  const T r4 = r2 * r2;
  const T r6 = r4 * r2;
  T radial = T(1.0) + k[0] * r2 + k[1] * r4 + k[4] * r6;
  if (rational) {
    const T denominator = T(1.0) + k[5] * r2 + k[6] * r4 + k[7] * r6;
    if (value(denominator) <= 0.0) return false;
    radial = radial / denominator;
  }
  const T xy = x * y;
  *xd = x * radial + T(2.0) * k[2] * xy + k[3] * (r2 + T(2.0) * x * x);
  *yd = y * radial + k[2] * (r2 + T(2.0) * y * y) + T(2.0) * k[3] * xy;
  return true;
}

}  // namespace camera_models_detail

/// Ideal pinhole. Parameters: fx fy cx cy [px].
struct PinholeModel {
  static constexpr CameraModelId kId = CameraModelId::kPinhole;
  static constexpr const char* kName = "pinhole";

  int numParams() const { return 4; }
  std::vector<std::string> paramNames() const;

  /// False for z <= 0.
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    const T& z = p_in_camera[2];
    if (camera_models_detail::value(z) <= 0.0) return false;
    camera_models_detail::applyIntrinsics(params, p_in_camera[0] / z, p_in_camera[1] / z, pixel);
    return true;
  }
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  /// At most pi/2 minus a micro-radian.
  double maxIncidenceAngle(const double* params, int width, int height) const;
};

/// OpenCV / ROS "plumb_bob" with 5 coefficients: pinhole plus radial (k1 k2 k3)
/// and tangential (p1 p2) distortion, as cv::projectPoints. Parameters:
/// fx fy cx cy [px], k1 k2 p1 p2 k3.
struct RadTanModel {
  static constexpr CameraModelId kId = CameraModelId::kRadTan;
  static constexpr const char* kName = "radtan";

  int numParams() const { return 9; }
  std::vector<std::string> paramNames() const;

  /// False for z <= 0.
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    const T& z = p_in_camera[2];
    if (camera_models_detail::value(z) <= 0.0) return false;
    const T k[8] = {params[4], params[5], params[6], params[7], params[8], T(0.0), T(0.0), T(0.0)};
    T xd, yd;
    camera_models_detail::distortOpenCv(k, false, p_in_camera[0] / z, p_in_camera[1] / z, &xd, &yd);
    camera_models_detail::applyIntrinsics(params, xd, yd, pixel);
    return true;
  }
  /// Newton iterations on the distortion; false when they do not converge.
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  double maxIncidenceAngle(const double* params, int width, int height) const;
};

/// OpenCV "rational polynomial" with 8 coefficients: radial distortion
/// (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6) plus
/// tangential p1 p2, as cv::projectPoints. Parameters:
/// fx fy cx cy [px], k1 k2 p1 p2 k3 k4 k5 k6.
struct RationalPolynomialModel {
  static constexpr CameraModelId kId = CameraModelId::kRationalPolynomial;
  static constexpr const char* kName = "rational_polynomial";

  int numParams() const { return 12; }
  std::vector<std::string> paramNames() const;

  /// False for z <= 0 and where the rational denominator is not positive.
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    const T& z = p_in_camera[2];
    if (camera_models_detail::value(z) <= 0.0) return false;
    T xd, yd;
    if (!camera_models_detail::distortOpenCv(params + 4, true, p_in_camera[0] / z,
                                             p_in_camera[1] / z, &xd, &yd)) {
      return false;
    }
    camera_models_detail::applyIntrinsics(params, xd, yd, pixel);
    return true;
  }
  /// Newton iterations on the distortion; false when they do not converge.
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  double maxIncidenceAngle(const double* params, int width, int height) const;
};

/// Kannala-Brandt / OpenCV fisheye / ROS "equidistant" / Kalibr "pinhole-equi":
/// theta = angle to the optical axis, theta_d = theta (1 + k1 theta^2 +
/// k2 theta^4 + k3 theta^6 + k4 theta^8), pixel = f theta_d (x, y) / r + c
/// with r = |(x, y)|. Valid beyond 90 degrees (theta up to pi). Parameters:
/// fx fy cx cy [px], k1 k2 k3 k4.
struct KannalaBrandtModel {
  static constexpr CameraModelId kId = CameraModelId::kKannalaBrandt;
  static constexpr const char* kName = "kannala_brandt";

  int numParams() const { return 8; }
  std::vector<std::string> paramNames() const;

  /// False at the centre of projection and straight behind the camera.
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    using camera_models_detail::value;
    using std::atan2;
    using std::sqrt;
    const T& x = p_in_camera[0];
    const T& y = p_in_camera[1];
    const T& z = p_in_camera[2];
    const T r2 = x * x + y * y;
    T scale;  // theta_d / r
    if (value(r2) > 0.0) {
      const T r = sqrt(r2);
      const T theta = atan2(r, z);
      const T theta2 = theta * theta;
      const T poly =
          T(1.0) +
          theta2 * (params[4] + theta2 * (params[5] + theta2 * (params[6] + theta2 * params[7])));
      scale = theta * poly / r;
    } else {
      if (value(z) <= 0.0) return false;
      scale = T(1.0) / z;  // limit of theta_d / r on the axis
    }
    camera_models_detail::applyIntrinsics(params, scale * x, scale * y, pixel);
    return true;
  }
  /// Newton iterations on theta; false when they do not converge in [0, pi].
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  /// Up to pi for fisheye lenses, limited by the monotonic range of theta_d.
  double maxIncidenceAngle(const double* params, int width, int height) const;
};

/// Scaramuzza's omnidirectional model (OCamCalib, 2006). Parameters:
/// cx cy [px] (image column and row of the distortion centre, in lookboth's
/// pixel convention), c d e (affine sensor-to-image matrix), a0..a_{n-1}
/// (direct polynomial, pixels), inv0..inv_{m-1} (inverse polynomial, optional).
///
/// In OCamCalib's frame (x_o = image rows = our y, y_o = columns = our x,
/// z_o = -our z) a pixel maps to sensor coordinates (x_o, y_o) through
/// [row - cy; col - cx] = [[c, d], [e, 1]] [x_o; y_o], and to the ray
/// (x_o, y_o, poly(rho)) with rho = |(x_o, y_o)| and poly(rho) = sum a_i rho^i
/// (a0 < 0). Projection is the exact inverse of that polynomial (solved by
/// Newton, seeded by the inverse polynomial when there is one), so project and
/// unproject agree to machine precision.
struct ScaramuzzaModel {
  static constexpr CameraModelId kId = CameraModelId::kScaramuzza;
  static constexpr const char* kName = "scaramuzza";

  int num_poly = 5;      ///< Number of direct polynomial coefficients a0..a_{n-1} (>= 2).
  int num_inv_poly = 0;  ///< Number of inverse polynomial coefficients (>= 0).

  int numParams() const { return 5 + num_poly + num_inv_poly; }
  std::vector<std::string> paramNames() const;

  /// False at the centre of projection, straight behind the camera, and when
  /// no sensor radius maps to the point's direction.
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    using camera_models_detail::value;
    using std::sqrt;
    const T& x = p_in_camera[0];
    const T& y = p_in_camera[1];
    const T& z = p_in_camera[2];
    double mu_value = 0.0;
    if constexpr (std::is_same_v<T, double>) {
      if (!solveSensorScale(params, x, y, z, &mu_value)) return false;
    } else {
      // The parameters' values on the stack (no allocation per projection),
      // on the heap only for an unusually long polynomial.
      constexpr int kOnStack = 32;
      const int n = numParams();
      double on_stack[kOnStack];
      std::vector<double> on_heap(n > kOnStack ? static_cast<std::size_t>(n) : 0);
      double* params_value = n > kOnStack ? on_heap.data() : on_stack;
      for (int i = 0; i < n; ++i) params_value[i] = value(params[i]);
      if (!solveSensorScale(params_value, value(x), value(y), value(z), &mu_value)) return false;
    }
    // One Newton step in T on h(mu) = poly(mu * norm) + z * mu, from the
    // converged root: its value is unchanged and its derivatives are the
    // implicit-function derivatives -dh/d(.) / h'(mu).
    const T norm2 = x * x + y * y;
    const T norm = value(norm2) > 0.0 ? T(sqrt(norm2)) : T(0.0);
    const T mu0(mu_value);
    const T rho = mu0 * norm;
    const T* a = params + 5;
    T poly = a[num_poly - 1];
    T dpoly(0.0);
    for (int i = num_poly - 2; i >= 0; --i) {
      dpoly = dpoly * rho + poly;
      poly = poly * rho + a[i];
    }
    const T h = poly + z * mu0;
    const T dh = dpoly * norm + z;
    const T mu = mu0 - h / dh;
    const T xo = mu * y;  // sensor coordinates, OCamCalib frame
    const T yo = mu * x;
    pixel[0] = params[4] * xo + yo + params[0];              // column
    pixel[1] = params[2] * xo + params[3] * yo + params[1];  // row
    return true;
  }
  /// Closed form (the direct polynomial); false when the pixel lies beyond a
  /// fold of the polynomial (projecting the ray would give another pixel).
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  /// Up to pi, limited by the range of rho over which the ray angle grows.
  double maxIncidenceAngle(const double* params, int width, int height) const;

  /// Solves poly(mu * norm) + z * mu = 0 for the scale mu > 0 that maps the
  /// point (x, y, z) to sensor coordinates (x_o, y_o) = mu * (y, x), taking
  /// the smallest sensor radius rho = mu * norm with that ray direction.
  /// False when there is none (or at the centre of projection).
  bool solveSensorScale(const double* params, double x, double y, double z, double* mu) const;
};

/// Double sphere (Usenko, Demmel, Cremers 2018). Parameters: fx fy cx cy [px],
/// xi, alpha. Valid for points with z > -w2 |p| (see the paper).
struct DoubleSphereModel {
  static constexpr CameraModelId kId = CameraModelId::kDoubleSphere;
  static constexpr const char* kName = "double_sphere";

  int numParams() const { return 6; }
  std::vector<std::string> paramNames() const;

  /// False at the centre of projection and outside the model's valid region.
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    using camera_models_detail::value;
    using std::sqrt;
    const T& x = p_in_camera[0];
    const T& y = p_in_camera[1];
    const T& z = p_in_camera[2];
    const T& xi = params[4];
    const T& alpha = params[5];
    const T r2 = x * x + y * y;
    const double d1_value = std::sqrt(value(r2) + value(z) * value(z));
    if (!(d1_value > 0.0)) return false;
    if (!(value(z) > -validityW2(value(xi), value(alpha)) * d1_value)) return false;
    const T d1 = sqrt(r2 + z * z);
    const T k = xi * d1 + z;
    const T d2 = sqrt(r2 + k * k);
    const T denominator = alpha * d2 + (T(1.0) - alpha) * k;
    if (!(value(denominator) > 0.0)) return false;
    camera_models_detail::applyIntrinsics(params, x / denominator, y / denominator, pixel);
    return true;
  }
  /// Closed form; false outside the valid circle (alpha > 0.5).
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  /// At most acos(-w2) (the model's valid region) minus a micro-radian.
  double maxIncidenceAngle(const double* params, int width, int height) const;

  /// w2 of the paper: points with z > -w2 |p| are valid.
  static double validityW2(double xi, double alpha) {
    const double w1 = alpha <= 0.5 ? alpha / (1.0 - alpha) : (1.0 - alpha) / alpha;
    return (w1 + xi) / std::sqrt(2.0 * w1 * xi + xi * xi + 1.0);
  }
};

/// Extended unified camera model (Khomutenko, Garcia, Martinet 2016; Kalibr's
/// and basalt's `eucm`). Parameters: fx fy cx cy [px], alpha in [0, 1],
/// beta > 0. With d = sqrt(beta (x^2 + y^2) + z^2), the pixel is
/// f (x, y) / (alpha d + (1 - alpha) z) + c; valid for z > -w d, where
/// w = alpha / (1 - alpha) for alpha <= 0.5, else (1 - alpha) / alpha.
struct EucmModel {
  static constexpr CameraModelId kId = CameraModelId::kEucm;
  static constexpr const char* kName = "eucm";

  int numParams() const { return 6; }
  std::vector<std::string> paramNames() const;

  /// False at the centre of projection and outside the model's valid region.
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    using camera_models_detail::value;
    using std::sqrt;
    const T& x = p_in_camera[0];
    const T& y = p_in_camera[1];
    const T& z = p_in_camera[2];
    const T& alpha = params[4];
    const T& beta = params[5];
    const T d2 = beta * (x * x + y * y) + z * z;
    if (!(value(d2) > 0.0)) return false;
    const T d = sqrt(d2);
    if (!(value(z) > -validityW(value(alpha)) * value(d))) return false;
    const T denominator = alpha * d + (T(1.0) - alpha) * z;
    if (!(value(denominator) > 0.0)) return false;
    camera_models_detail::applyIntrinsics(params, x / denominator, y / denominator, pixel);
    return true;
  }
  /// Closed form; false outside the valid circle (alpha > 0.5).
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  /// At most the valid region's angle minus a micro-radian.
  double maxIncidenceAngle(const double* params, int width, int height) const;

  /// w: points with z > -w d are valid.
  static double validityW(double alpha) {
    return alpha <= 0.5 ? alpha / (1.0 - alpha) : (1.0 - alpha) / alpha;
  }
};

/// Mei's unified omnidirectional model with radial-tangential distortion
/// (Mei and Rives 2007; Kalibr's `omni-radtan`, CamOdoCal's `MEI`, OpenCV's
/// `cv::omnidir` without skew). Parameters: fx fy cx cy [px] (Kalibr's
/// gamma1 gamma2 u0 v0), xi >= 0, k1 k2 p1 p2. The point is put on the unit
/// sphere, projected from (0, 0, -xi) to the plane z = 1, distorted as
/// OpenCV's radtan (k3 = 0), then scaled by f and shifted by c. Valid for
/// z / |p| > -w, where w = xi for xi <= 1, else 1 / xi.
struct MeiModel {
  static constexpr CameraModelId kId = CameraModelId::kMei;
  static constexpr const char* kName = "mei";

  int numParams() const { return 9; }
  std::vector<std::string> paramNames() const;

  /// False at the centre of projection and outside the model's valid region.
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    using camera_models_detail::value;
    using std::sqrt;
    const T& x = p_in_camera[0];
    const T& y = p_in_camera[1];
    const T& z = p_in_camera[2];
    const T& xi = params[4];
    const T n2 = x * x + y * y + z * z;
    if (!(value(n2) > 0.0)) return false;
    const T n = sqrt(n2);
    if (!(value(z) > -validityW(value(xi)) * value(n))) return false;
    const T denominator = z + xi * n;
    if (!(value(denominator) > 0.0)) return false;
    const T mx = x / denominator;
    const T my = y / denominator;
    const T k[8] = {params[5], params[6], params[7], params[8], T(0.0), T(0.0), T(0.0), T(0.0)};
    T xd, yd;
    camera_models_detail::distortOpenCv(k, false, mx, my, &xd, &yd);
    camera_models_detail::applyIntrinsics(params, xd, yd, pixel);
    return true;
  }
  /// Undistorts iteratively, then lifts to the sphere in closed form.
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  double maxIncidenceAngle(const double* params, int width, int height) const;

  /// w: points with z / |p| > -w are valid.
  static double validityW(double xi) { return xi <= 1.0 ? xi : 1.0 / xi; }
};

/// The field-of-view model (Devernay and Faugeras 2001; Kalibr's
/// `pinhole-fov`, PTAM's and DSO's ATAN/FOV). Parameters: fx fy cx cy [px],
/// w [rad] in (0, pi). A point at distance r = |(x, y)| / z from the axis
/// on the plane z = 1 is moved to r_d = atan(2 r tan(w / 2)) / w; valid in
/// front of the camera (z > 0).
struct FovModel {
  static constexpr CameraModelId kId = CameraModelId::kFov;
  static constexpr const char* kName = "fov";

  int numParams() const { return 5; }
  std::vector<std::string> paramNames() const;

  /// False behind the camera or on its plane (z <= 0).
  template <typename T>
  bool project(const T* params, const T* p_in_camera, T* pixel) const {
    using camera_models_detail::value;
    using std::atan;
    using std::sqrt;
    using std::tan;
    const T& z = p_in_camera[2];
    if (!(value(z) > 0.0)) return false;
    const T mx = p_in_camera[0] / z;
    const T my = p_in_camera[1] / z;
    const T& w = params[4];
    const T r2 = mx * mx + my * my;
    // r_d / r, and its limit 2 tan(w / 2) / w on the axis (where sqrt has no derivative).
    const T two_tan = T(2.0) * tan(w / T(2.0));
    T factor = two_tan / w;
    if (value(r2) > 1e-16) {
      const T r = sqrt(r2);
      factor = atan(r * two_tan) / (w * r);
    }
    camera_models_detail::applyIntrinsics(params, mx * factor, my * factor, pixel);
    return true;
  }
  /// Closed form; false beyond r_d = pi / (2 w) (the image of the plane z = 0).
  bool unproject(const double* params, const double* pixel, double* bearing) const;
  std::string validate(const double* params, int width, int height) const;
  double maxIncidenceAngle(const double* params, int width, int height) const;
};

}  // namespace lookboth
