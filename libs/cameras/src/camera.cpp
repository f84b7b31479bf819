#include "lookboth/cameras/camera.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <tuple>
#include <utility>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth {
namespace {

constexpr double kPi = 3.14159265358979323846;
/// Kept away from a model's hard limit (pi/2 for pinhole models...) [rad].
constexpr double kLimitMargin = 1e-6;
/// Field of view beyond the image border kept valid: 5% of the border angle.
constexpr double kCoverMargin = 1.05;
/// The model counts as smooth (and safely away from a fold) while the
/// Jacobian of the pixel with respect to the equidistant coordinates
/// theta * (cos phi, sin phi) keeps its orientation and its smallest singular
/// value stays above this fraction of its value on the optical axis. For
/// Scaramuzza, the same fraction bounds d angle / d rho.
constexpr double kMinJacobianRatio = 0.05;
/// Slack on the incidence-angle test: unproject accepts angles up to
/// max + kUnprojectSlack, project up to max + kProjectSlack, so that any
/// bearing returned by unproject can be projected again.
constexpr double kUnprojectSlack = 1e-9;
constexpr double kProjectSlack = 2e-9;

std::string fmt(double value) { return formatDouble(value); }

/// Angle between a vector and +z [rad], in [0, pi].
double incidenceAngle(const double* v) { return std::atan2(std::hypot(v[0], v[1]), v[2]); }

void normalize3(double* v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  v[0] /= n;
  v[1] /= n;
  v[2] /= n;
}

/// Scales `v` to unit length; false (and `v` left as it is) when it has no
/// direction: a zero, infinite or NaN length.
bool normalizeDirection(double* v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (!(n > 0.0) || !std::isfinite(n)) return false;
  normalize3(v);
  return true;
}

/// Points on the border of the image area (pixel edges, not centres):
/// the corners and evenly spaced points along each side.
std::vector<Eigen::Vector2d> borderPixels(int width, int height) {
  constexpr int kPerSide = 16;
  const double u0 = -0.5, u1 = width - 0.5, v0 = -0.5, v1 = height - 0.5;
  std::vector<Eigen::Vector2d> out;
  out.reserve(4 * kPerSide);
  for (int i = 0; i < kPerSide; ++i) {
    const double t = static_cast<double>(i) / kPerSide;
    out.emplace_back(u0 + t * (u1 - u0), v0);
    out.emplace_back(u1, v0 + t * (v1 - v0));
    out.emplace_back(u1 - t * (u1 - u0), v1);
    out.emplace_back(u0, v1 - t * (v1 - v0));
  }
  return out;
}

/// First crossing of f(x) = 0 on [lo, hi] for a function that rises from
/// f(lo) < 0 (its monotonic branch) and may fold back later: Newton's method
/// safeguarded by bisection, where a point with f(x) < 0 that is `past_fold`
/// bounds the search from above like a point with f(x) >= 0 does. False when
/// f stays negative on the rising branch. `f(x, &value, &derivative)`.
template <typename F, typename PastFold>
bool solveFirstCrossing(const F& f, const PastFold& past_fold, double lo, double hi, double x,
                        double* root) {
  constexpr double kEps = 4.0 * std::numeric_limits<double>::epsilon();
  // A Newton step this small (relative) is taken and ends the search: the
  // error after it is of the order of its square, below f's rounding, where
  // waiting for a step of kEps let f's rounding noise bounce the iterates
  // (8.6 evaluations per OCamCalib projection instead of about 4).
  constexpr double kNewtonStep = 1e-10;
  bool crossed = false;  // f(hi) >= 0
  if (!(x > lo && x < hi)) x = 0.5 * (lo + hi);
  double step = hi - lo, previous_step = step;
  for (int iteration = 0; iteration < 200; ++iteration) {
    double fx = 0.0, dfx = 0.0;
    f(x, &fx, &dfx);
    if (!std::isfinite(fx)) return false;
    if (fx >= 0.0) {
      if (fx == 0.0) {
        *root = x;
        return true;
      }
      hi = x;
      crossed = true;
    } else if (past_fold(x, dfx)) {
      hi = x;
    } else {
      lo = x;
    }
    // Newton's step, unless it leaves the bracket or does not at least halve
    // the step before last (which stops cycles).
    double next = x - fx / dfx;
    const bool newton_ok =
        dfx > 0.0 && next > lo && next < hi && std::abs(next - x) <= 0.5 * previous_step;
    if (newton_ok && std::abs(next - x) <= kNewtonStep * std::abs(x)) {
      *root = next;
      return true;
    }
    if (!newton_ok) next = 0.5 * (lo + hi);
    previous_step = step;
    step = std::abs(next - x);
    if (hi - lo <= kEps * std::abs(hi)) {
      if (!crossed) return false;
      *root = hi;
      return true;
    }
    x = next;
  }
  return false;
}

/// Checks fx fy cx cy: positive focal lengths, principal point in the image.
std::string validateIntrinsics(const double* p, int width, int height) {
  if (!(p[0] > 0.0)) return "'fx': must be positive, got " + fmt(p[0]);
  if (!(p[1] > 0.0)) return "'fy': must be positive, got " + fmt(p[1]);
  if (p[2] < -0.5 || p[2] > width - 0.5) {
    return "'cx': must lie inside the image [-0.5, " + fmt(width - 0.5) + "], got " + fmt(p[2]);
  }
  if (p[3] < -0.5 || p[3] > height - 0.5) {
    return "'cy': must lie inside the image [-0.5, " + fmt(height - 0.5) + "], got " + fmt(p[3]);
  }
  return {};
}

/// Unit direction of the equidistant coordinates q = theta * (cos phi, sin phi).
void equidistantDirection(double q1, double q2, double* direction) {
  const double t = std::hypot(q1, q2);
  if (t == 0.0) {
    direction[0] = 0.0;
    direction[1] = 0.0;
    direction[2] = 1.0;
    return;
  }
  const double s = std::sin(t) / t;
  direction[0] = s * q1;
  direction[1] = s * q2;
  direction[2] = std::cos(t);
}

/// The pixel at q = theta (cos phi, sin phi) and the smallest singular value
/// of d pixel / d q there (central differences), negative when the Jacobian
/// flips the orientation. False when the model cannot project there.
template <typename Model>
bool equidistantJacobian(const Model& model, const double* params, double theta, double phi,
                         Eigen::Vector2d* pixel, double* min_singular) {
  constexpr double kStep = 1e-5;
  const double q1 = theta * std::cos(phi), q2 = theta * std::sin(phi);
  const double offsets[4][2] = {{kStep, 0.0}, {-kStep, 0.0}, {0.0, kStep}, {0.0, -kStep}};
  double pixels[4][2];
  for (int i = 0; i < 4; ++i) {
    double direction[3];
    equidistantDirection(q1 + offsets[i][0], q2 + offsets[i][1], direction);
    if (!model.project(params, direction, pixels[i])) return false;
  }
  const double scale = 1.0 / (2.0 * kStep);
  const double j00 = (pixels[0][0] - pixels[1][0]) * scale;
  const double j10 = (pixels[0][1] - pixels[1][1]) * scale;
  const double j01 = (pixels[2][0] - pixels[3][0]) * scale;
  const double j11 = (pixels[2][1] - pixels[3][1]) * scale;
  const double det = j00 * j11 - j01 * j10;
  const double half_sum = 0.5 * (j00 * j00 + j01 * j01 + j10 * j10 + j11 * j11);
  const double largest =
      std::sqrt(half_sum + std::sqrt(std::max(0.0, half_sum * half_sum - det * det)));
  *min_singular = det / largest;  // det is the signed product of the singular values
  *pixel = Eigen::Vector2d(pixels[0][0] + pixels[1][0], pixels[0][1] + pixels[1][1]) * 0.5;
  return std::isfinite(*min_singular) && pixel->allFinite();
}

/// Largest incidence angle up to which `model` is one-to-one and smooth, no
/// more than `limit`, than the angle of the image border plus a margin, and
/// than the angle where pixels get two image diagonals away from the
/// principal point. Marches outwards along azimuths until the local Jacobian
/// degenerates. `pinhole_type`: distortion polynomials in tan(theta), whose
/// features are uniformly spread in log(tan(theta)): the steps are too
/// (requires limit < pi/2).
template <typename Model>
double scanMaxIncidenceAngle(const Model& model, const double* params, int width, int height,
                             double limit, bool pinhole_type) {
  bool covered = true;
  double cover_angle = 0.0;
  for (const Eigen::Vector2d& pixel : borderPixels(width, height)) {
    double bearing[3];
    if (model.unproject(params, pixel.data(), bearing)) {
      cover_angle = std::max(cover_angle, incidenceAngle(bearing));
    } else {
      covered = false;
    }
  }
  const double end = covered ? std::min(limit, kCoverMargin * cover_angle) : limit;
  Eigen::Vector2d centre;
  double reference = 0.0;
  if (!equidistantJacobian(model, params, 0.0, 0.0, &centre, &reference) || !(reference > 0.0)) {
    return 0.0;
  }
  const double far = 2.0 * std::hypot(width, height);
  const auto smooth = [&](double theta, double phi, bool* too_far) {
    Eigen::Vector2d pixel;
    double min_singular = 0.0;
    if (!equidistantJacobian(model, params, theta, phi, &pixel, &min_singular)) return false;
    *too_far = (pixel - centre).norm() > far;
    return min_singular > kMinJacobianRatio * reference;
  };
  constexpr int kAzimuths = 32;
  constexpr double kMaxStep = 0.2 * kPi / 180.0;
  constexpr double kLogStep = 0.005;
  double result = end;
  for (int a = 0; a < kAzimuths; ++a) {
    const double phi = 2.0 * kPi * a / kAzimuths;
    double good = 0.0;
    while (good < result) {
      double step = kMaxStep;
      if (pinhole_type) {  // d theta = cos^2 theta d tan theta
        const double c = std::cos(good);
        step = std::max(1e-12, std::min(step, kLogStep * std::max(std::tan(good), 0.5) * c * c));
      }
      const double theta = std::min(good + step, result);
      bool too_far = false;
      if (smooth(theta, phi, &too_far)) {
        if (too_far) result = theta;
        good = theta;
        continue;
      }
      double bad = theta;
      for (int i = 0; i < 40; ++i) {
        const double mid = 0.5 * (good + bad);
        (smooth(mid, phi, &too_far) ? good : bad) = mid;
      }
      result = std::min(result, good);
      break;
    }
  }
  return result;
}

/// OpenCV distortion of normalized coordinates with its Jacobian; k holds
/// k1 k2 p1 p2 k3 k4 k5 k6 (k4..k6 unused unless `rational`).
bool distortWithJacobian(const double* k, bool rational, double x, double y, double* xd, double* yd,
                         double* jacobian) {
  const double r2 = x * x + y * y;
  const double a = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[4]));
  const double da = k[0] + r2 * (2.0 * k[1] + 3.0 * r2 * k[4]);
  double b = 1.0, db = 0.0;
  if (rational) {
    b = 1.0 + r2 * (k[5] + r2 * (k[6] + r2 * k[7]));
    db = k[5] + r2 * (2.0 * k[6] + 3.0 * r2 * k[7]);
    if (!(b > 0.0)) return false;
  }
  const double radial = a / b;
  const double dradial = (da * b - a * db) / (b * b);  // d radial / d r2
  const double p1 = k[2], p2 = k[3];
  *xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
  *yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
  const double cross = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y;
  jacobian[0] = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x;
  jacobian[1] = cross;
  jacobian[2] = cross;
  jacobian[3] = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x;
  return true;
}

/// Inverts the OpenCV distortion by damped Newton iterations.
bool undistortOpenCv(const double* k, bool rational, double xd, double yd, double* x, double* y) {
  // Start from the distorted point, pulled towards the centre until the
  // distortion is locally one-to-one there (strong pincushion distortion puts
  // the distorted point past the fold).
  double cx = xd, cy = yd;
  double fx, fy, jacobian[4];
  for (int attempt = 0;; ++attempt) {
    if (attempt == 60) return false;
    if (distortWithJacobian(k, rational, cx, cy, &fx, &fy, jacobian) &&
        jacobian[0] * jacobian[3] - jacobian[1] * jacobian[2] > 0.0) {
      break;
    }
    cx *= 0.5;
    cy *= 0.5;
  }
  double residual = std::hypot(fx - xd, fy - yd);
  const double tolerance =
      4.0 * std::numeric_limits<double>::epsilon() * (1.0 + std::hypot(xd, yd));
  for (int iteration = 0; iteration < 100 && residual > tolerance; ++iteration) {
    const double det = jacobian[0] * jacobian[3] - jacobian[1] * jacobian[2];
    if (!(det > 0.0)) return false;
    const double rx = fx - xd, ry = fy - yd;
    const double sx = (jacobian[3] * rx - jacobian[1] * ry) / det;
    const double sy = (-jacobian[2] * rx + jacobian[0] * ry) / det;
    double step = 1.0;
    bool improved = false;
    for (int halving = 0; halving < 40; ++halving, step *= 0.5) {
      const double nx = cx - step * sx, ny = cy - step * sy;
      double gx, gy, g_jacobian[4];
      if (!distortWithJacobian(k, rational, nx, ny, &gx, &gy, g_jacobian)) continue;
      // Stay where the distortion is locally one-to-one: a root past a fold
      // is not the ray the pixel came from.
      if (!(g_jacobian[0] * g_jacobian[3] - g_jacobian[1] * g_jacobian[2] > 0.0)) continue;
      const double new_residual = std::hypot(gx - xd, gy - yd);
      if (new_residual < residual) {
        cx = nx;
        cy = ny;
        fx = gx;
        fy = gy;
        std::copy(g_jacobian, g_jacobian + 4, jacobian);
        residual = new_residual;
        improved = true;
        break;
      }
    }
    if (!improved) break;  // at the rounding floor, or stuck
  }
  if (!(residual <= 1e-11 * (1.0 + std::hypot(xd, yd)))) return false;
  *x = cx;
  *y = cy;
  return true;
}

bool unprojectOpenCv(const double* params, bool rational, const double* pixel, double* bearing) {
  const double xd = (pixel[0] - params[2]) / params[0];
  const double yd = (pixel[1] - params[3]) / params[1];
  double k[8] = {params[4], params[5], params[6], params[7], params[8], 0.0, 0.0, 0.0};
  if (rational) std::copy(params + 9, params + 12, k + 5);
  double x, y;
  if (!undistortOpenCv(k, rational, xd, yd, &x, &y)) return false;
  bearing[0] = x;
  bearing[1] = y;
  bearing[2] = 1.0;
  normalize3(bearing);
  return true;
}

std::vector<std::string> withIntrinsics(std::vector<std::string> distortion) {
  std::vector<std::string> names = {"fx", "fy", "cx", "cy"};
  names.insert(names.end(), distortion.begin(), distortion.end());
  return names;
}

/// Sum a_i x^i and its derivative.
double evalPolynomial(const double* a, int n, double x, double* derivative) {
  double value = a[n - 1], d = 0.0;
  for (int i = n - 2; i >= 0; --i) {
    d = d * x + value;
    value = value * x + a[i];
  }
  if (derivative) *derivative = d;
  return value;
}

}  // namespace

// ---------------------------------------------------------------- pinhole

std::vector<std::string> PinholeModel::paramNames() const { return withIntrinsics({}); }

bool PinholeModel::unproject(const double* params, const double* pixel, double* bearing) const {
  bearing[0] = (pixel[0] - params[2]) / params[0];
  bearing[1] = (pixel[1] - params[3]) / params[1];
  bearing[2] = 1.0;
  normalize3(bearing);
  return true;
}

std::string PinholeModel::validate(const double* params, int width, int height) const {
  return validateIntrinsics(params, width, height);
}

double PinholeModel::maxIncidenceAngle(const double* params, int width, int height) const {
  return scanMaxIncidenceAngle(*this, params, width, height, 0.5 * kPi - kLimitMargin, true);
}

// ---------------------------------------------------------------- radtan

std::vector<std::string> RadTanModel::paramNames() const {
  return withIntrinsics({"k1", "k2", "p1", "p2", "k3"});
}

bool RadTanModel::unproject(const double* params, const double* pixel, double* bearing) const {
  return unprojectOpenCv(params, false, pixel, bearing);
}

std::string RadTanModel::validate(const double* params, int width, int height) const {
  return validateIntrinsics(params, width, height);
}

double RadTanModel::maxIncidenceAngle(const double* params, int width, int height) const {
  return scanMaxIncidenceAngle(*this, params, width, height, 0.5 * kPi - kLimitMargin, true);
}

// ---------------------------------------------------------------- rational polynomial

std::vector<std::string> RationalPolynomialModel::paramNames() const {
  return withIntrinsics({"k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"});
}

bool RationalPolynomialModel::unproject(const double* params, const double* pixel,
                                        double* bearing) const {
  return unprojectOpenCv(params, true, pixel, bearing);
}

std::string RationalPolynomialModel::validate(const double* params, int width, int height) const {
  return validateIntrinsics(params, width, height);
}

double RationalPolynomialModel::maxIncidenceAngle(const double* params, int width,
                                                  int height) const {
  return scanMaxIncidenceAngle(*this, params, width, height, 0.5 * kPi - kLimitMargin, true);
}

// ---------------------------------------------------------------- Kannala-Brandt

std::vector<std::string> KannalaBrandtModel::paramNames() const {
  return withIntrinsics({"k1", "k2", "k3", "k4"});
}

bool KannalaBrandtModel::unproject(const double* params, const double* pixel,
                                   double* bearing) const {
  const double mx = (pixel[0] - params[2]) / params[0];
  const double my = (pixel[1] - params[3]) / params[1];
  const double theta_d = std::hypot(mx, my);
  if (!std::isfinite(theta_d)) return false;
  if (theta_d == 0.0) {
    bearing[0] = 0.0;
    bearing[1] = 0.0;
    bearing[2] = 1.0;
    return true;
  }
  const double* k = params + 4;
  const auto f = [&](double theta, double* value, double* derivative) {
    const double t2 = theta * theta;
    *value = theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])))) - theta_d;
    *derivative = 1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
  };
  const auto past_fold = [](double, double derivative) { return !(derivative > 0.0); };
  double theta = 0.0;
  if (!solveFirstCrossing(f, past_fold, 0.0, kPi, std::min(theta_d, kPi), &theta)) return false;
  const double s = std::sin(theta) / theta_d;
  bearing[0] = s * mx;
  bearing[1] = s * my;
  bearing[2] = std::cos(theta);
  return true;
}

std::string KannalaBrandtModel::validate(const double* params, int width, int height) const {
  return validateIntrinsics(params, width, height);
}

double KannalaBrandtModel::maxIncidenceAngle(const double* params, int width, int height) const {
  return scanMaxIncidenceAngle(*this, params, width, height, kPi - kLimitMargin, false);
}

// ---------------------------------------------------------------- double sphere

std::vector<std::string> DoubleSphereModel::paramNames() const {
  return withIntrinsics({"xi", "alpha"});
}

bool DoubleSphereModel::unproject(const double* params, const double* pixel,
                                  double* bearing) const {
  const double xi = params[4], alpha = params[5];
  const double mx = (pixel[0] - params[2]) / params[0];
  const double my = (pixel[1] - params[3]) / params[1];
  const double r2 = mx * mx + my * my;
  const double inside = 1.0 - (2.0 * alpha - 1.0) * r2;
  if (!(inside >= 0.0)) return false;  // outside the valid circle (alpha > 0.5)
  const double mz = (1.0 - alpha * alpha * r2) / (alpha * std::sqrt(inside) + 1.0 - alpha);
  const double discriminant = mz * mz + (1.0 - xi * xi) * r2;
  if (!(discriminant >= 0.0)) return false;
  const double scale = (mz * xi + std::sqrt(discriminant)) / (mz * mz + r2);
  bearing[0] = scale * mx;
  bearing[1] = scale * my;
  bearing[2] = scale * mz - xi;
  return normalizeDirection(bearing);
}

std::string DoubleSphereModel::validate(const double* params, int width, int height) const {
  std::string message = validateIntrinsics(params, width, height);
  if (!message.empty()) return message;
  if (!(params[4] > -1.0 && params[4] <= 1.0))
    return "'xi': must be in (-1, 1], got " + fmt(params[4]);
  if (!(params[5] >= 0.0 && params[5] <= 1.0)) {
    return "'alpha': must be in [0, 1], got " + fmt(params[5]);
  }
  return {};
}

double DoubleSphereModel::maxIncidenceAngle(const double* params, int width, int height) const {
  const double w2 = validityW2(params[4], params[5]);
  const double limit = std::acos(std::clamp(-w2, -1.0, 1.0)) - kLimitMargin;
  return scanMaxIncidenceAngle(*this, params, width, height, limit, false);
}

// ---------------------------------------------------------------- EUCM

std::vector<std::string> EucmModel::paramNames() const { return withIntrinsics({"alpha", "beta"}); }

bool EucmModel::unproject(const double* params, const double* pixel, double* bearing) const {
  const double alpha = params[4], beta = params[5];
  const double mx = (pixel[0] - params[2]) / params[0];
  const double my = (pixel[1] - params[3]) / params[1];
  const double r2 = mx * mx + my * my;
  const double inside = 1.0 - (2.0 * alpha - 1.0) * beta * r2;
  if (!(inside >= 0.0)) return false;  // outside the valid circle (alpha > 0.5)
  const double mz = (1.0 - beta * alpha * alpha * r2) / (alpha * std::sqrt(inside) + 1.0 - alpha);
  bearing[0] = mx;
  bearing[1] = my;
  bearing[2] = mz;
  return normalizeDirection(bearing);
}

std::string EucmModel::validate(const double* params, int width, int height) const {
  std::string message = validateIntrinsics(params, width, height);
  if (!message.empty()) return message;
  if (!(params[4] >= 0.0 && params[4] <= 1.0))
    return "'alpha': must be in [0, 1], got " + fmt(params[4]);
  if (!(params[5] > 0.0)) return "'beta': must be positive, got " + fmt(params[5]);
  return {};
}

double EucmModel::maxIncidenceAngle(const double* params, int width, int height) const {
  // The boundary z = -w d of the valid region, as an angle from the axis:
  // with d = sqrt(beta sin^2 + cos^2), tan^2(theta) = (1 - w^2) / (w^2 beta), cos < 0.
  // w >= 1 (alpha = 0.5) leaves every direction valid; w = 0 is a pinhole.
  const double w = validityW(params[4]);
  double limit = kPi;
  if (w < 1.0)
    limit = w > 0.0 ? kPi - std::atan(std::sqrt((1.0 - w * w) / (w * w * params[5]))) : 0.5 * kPi;
  return scanMaxIncidenceAngle(*this, params, width, height, limit - kLimitMargin, false);
}

// ---------------------------------------------------------------- Mei

std::vector<std::string> MeiModel::paramNames() const {
  return withIntrinsics({"xi", "k1", "k2", "p1", "p2"});
}

bool MeiModel::unproject(const double* params, const double* pixel, double* bearing) const {
  const double xi = params[4];
  const double xd = (pixel[0] - params[2]) / params[0];
  const double yd = (pixel[1] - params[3]) / params[1];
  const double k[8] = {params[5], params[6], params[7], params[8], 0.0, 0.0, 0.0, 0.0};
  double mx, my;
  if (!undistortOpenCv(k, false, xd, yd, &mx, &my)) return false;
  // The ray through (mx, my, 1) from (0, 0, -xi) meets the unit sphere at
  // lambda (mx, my, 1) - (0, 0, xi).
  const double r2 = mx * mx + my * my;
  const double discriminant = 1.0 + (1.0 - xi * xi) * r2;
  if (!(discriminant >= 0.0)) return false;
  const double lambda = (xi + std::sqrt(discriminant)) / (1.0 + r2);
  bearing[0] = lambda * mx;
  bearing[1] = lambda * my;
  bearing[2] = lambda - xi;
  return normalizeDirection(bearing);
}

std::string MeiModel::validate(const double* params, int width, int height) const {
  std::string message = validateIntrinsics(params, width, height);
  if (!message.empty()) return message;
  if (!(params[4] >= 0.0 && params[4] <= 100.0))
    return "'xi': must be in [0, 100], got " + fmt(params[4]);
  return {};
}

double MeiModel::maxIncidenceAngle(const double* params, int width, int height) const {
  // z / |p| > -w: the angle acos(-w) (xi = 0 is a pinhole: pi / 2).
  const double limit = std::acos(std::clamp(-validityW(params[4]), -1.0, 1.0));
  return scanMaxIncidenceAngle(*this, params, width, height, limit - kLimitMargin, false);
}

// ---------------------------------------------------------------- FOV

std::vector<std::string> FovModel::paramNames() const { return withIntrinsics({"w"}); }

bool FovModel::unproject(const double* params, const double* pixel, double* bearing) const {
  const double w = params[4];
  const double xd = (pixel[0] - params[2]) / params[0];
  const double yd = (pixel[1] - params[3]) / params[1];
  const double rd = std::hypot(xd, yd);
  const double two_tan = 2.0 * std::tan(0.5 * w);
  double factor = w / two_tan;  // r / r_d on the axis
  if (rd > 1e-12) {
    if (!(rd * w < 0.5 * kPi)) return false;  // beyond the image of the plane z = 0
    factor = std::tan(rd * w) / (two_tan * rd);
  }
  bearing[0] = xd * factor;
  bearing[1] = yd * factor;
  bearing[2] = 1.0;
  if (!std::isfinite(bearing[0]) || !std::isfinite(bearing[1])) return false;
  normalize3(bearing);
  return true;
}

std::string FovModel::validate(const double* params, int width, int height) const {
  std::string message = validateIntrinsics(params, width, height);
  if (!message.empty()) return message;
  if (!(params[4] > 0.0 && params[4] < kPi))
    return "'w': must be in (0, pi) rad, got " + fmt(params[4]);
  return {};
}

double FovModel::maxIncidenceAngle(const double* params, int width, int height) const {
  return scanMaxIncidenceAngle(*this, params, width, height, 0.5 * kPi - kLimitMargin, true);
}

// ---------------------------------------------------------------- Scaramuzza

std::vector<std::string> ScaramuzzaModel::paramNames() const {
  std::vector<std::string> names = {"cx", "cy", "c", "d", "e"};
  for (int i = 0; i < num_poly; ++i) names.push_back("a" + std::to_string(i));
  for (int i = 0; i < num_inv_poly; ++i) names.push_back("inv" + std::to_string(i));
  return names;
}

bool ScaramuzzaModel::solveSensorScale(const double* params, double x, double y, double z,
                                       double* mu) const {
  const double length = std::sqrt(x * x + y * y + z * z);
  if (!(length > 0.0) || !std::isfinite(length)) return false;
  const double* a = params + 5;
  const double norm = std::sqrt(x * x + y * y) / length;  // x, y, z are finite: no overflow
  const double t = z / length;
  if (norm == 0.0) {  // on the optical axis: poly(0) + t mu = 0
    if (!(t > 0.0)) return false;
    *mu = -a[0] / t / length;
    return true;
  }
  // g(rho) = norm * poly(rho) + t * rho, with g(0) = norm * a0 < 0; the wanted
  // root is the first one, where g turns positive. The last evaluation is
  // kept for the fold test, which the root finder asks about the same rho.
  double last_rho = std::numeric_limits<double>::quiet_NaN(), last_g = 0.0, last_dg = 0.0;
  const auto g = [&](double rho, double* value, double* derivative) {
    double dpoly = 0.0;
    last_g = *value = norm * evalPolynomial(a, num_poly, rho, &dpoly) + t * rho;
    last_dg = *derivative = norm * dpoly + t;
    last_rho = rho;
  };
  // Past the first fold of the ray angle atan2(rho, -poly(rho)), whose
  // derivative has the sign of rho poly'(rho) - poly(rho), which is
  // (rho g'(rho) - g(rho)) / norm.
  const auto past_fold = [&](double rho, double) {
    if (rho != last_rho) {
      double value = 0.0, derivative = 0.0;
      g(rho, &value, &derivative);
    }
    return !(rho * last_dg - last_g > 0.0);
  };
  const auto bounds_root = [&](double rho) {
    double value = 0.0, unused = 0.0;
    g(rho, &value, &unused);
    return !(value < 0.0) || past_fold(rho, 0.0);
  };
  // Bracket the first crossing: from the inverse-polynomial seed when there
  // is one, else from the centre, march outwards.
  double seed = -1.0;
  if (num_inv_poly > 0) {
    seed = evalPolynomial(params + 5 + num_poly, num_inv_poly, std::atan2(-t, norm), nullptr);
  }
  const double step = 0.25 * std::abs(a[0]);
  double lo = 0.0, hi = 0.0;
  const double first = seed > 0.0 && std::isfinite(seed) ? 1.05 * seed : step;
  if (bounds_root(first)) {
    hi = first;
  } else {
    lo = first;
    for (int k = 1; k <= 400 && hi == 0.0; ++k) {
      const double rho = first + k * step;
      if (bounds_root(rho)) {
        hi = rho;
      } else {
        lo = rho;
      }
    }
    if (hi == 0.0) return false;
  }
  double rho = 0.0;
  if (!solveFirstCrossing(g, past_fold, lo, hi, seed > 0.0 && seed < hi ? seed : 0.5 * (lo + hi),
                          &rho)) {
    return false;
  }
  *mu = rho / norm / length;
  return true;
}

bool ScaramuzzaModel::unproject(const double* params, const double* pixel, double* bearing) const {
  const double c = params[2], d = params[3], e = params[4];
  const double det = c - d * e;
  const double dr = pixel[1] - params[1];  // row offset
  const double dc = pixel[0] - params[0];  // column offset
  const double xo = (dr - d * dc) / det;
  const double yo = (c * dc - e * dr) / det;
  const double rho = std::hypot(xo, yo);
  const double zo = evalPolynomial(params + 5, num_poly, rho, nullptr);
  bearing[0] = yo;
  bearing[1] = xo;
  bearing[2] = -zo;
  if (!normalizeDirection(bearing)) return false;
  if (rho > 0.0) {
    // Beyond a fold of the polynomial the ray projects to another pixel.
    double mu = 0.0;
    if (!solveSensorScale(params, bearing[0], bearing[1], bearing[2], &mu)) return false;
    const double rho_back = mu * std::hypot(bearing[0], bearing[1]);
    if (!(std::abs(rho_back - rho) <= 1e-7 * (1.0 + rho))) return false;
  }
  return true;
}

std::string ScaramuzzaModel::validate(const double* params, int width, int height) const {
  if (num_poly < 2) {
    return "'a': the direct polynomial needs at least 2 coefficients, got " +
           std::to_string(num_poly);
  }
  if (num_inv_poly < 0) {
    return "'inv': the number of inverse polynomial coefficients must not be negative, got " +
           std::to_string(num_inv_poly);
  }
  if (params[0] < -0.5 || params[0] > width - 0.5) {
    return "'cx': the distortion centre must lie inside the image [-0.5, " + fmt(width - 0.5) +
           "], got " + fmt(params[0]);
  }
  if (params[1] < -0.5 || params[1] > height - 0.5) {
    return "'cy': the distortion centre must lie inside the image [-0.5, " + fmt(height - 0.5) +
           "], got " + fmt(params[1]);
  }
  const double det = params[2] - params[3] * params[4];
  if (!(det > 0.0)) {
    return "'c': the affine matrix [[c, d], [e, 1]] must have a positive determinant c - d*e, "
           "got " +
           fmt(det);
  }
  const double* a = params + 5;
  if (!(a[0] < 0.0)) {
    return "'a0': must be negative (OCamCalib's a0 is minus the focal length in pixels, with "
           "its z axis pointing away from the scene), got " +
           fmt(a[0]);
  }
  // The ray angle atan2(rho, -poly(rho)) must grow over the central part of
  // the image (10% of the distance to the farthest corner).
  double farthest = 0.0;
  for (const Eigen::Vector2d& pixel : borderPixels(width, height)) {
    const double dr = pixel.y() - params[1], dc = pixel.x() - params[0];
    farthest = std::max(
        farthest, std::hypot((dr - params[3] * dc) / det, (params[2] * dc - params[4] * dr) / det));
  }
  constexpr int kSamples = 100;
  for (int i = 0; i <= kSamples; ++i) {
    const double rho = 0.1 * farthest * i / kSamples;
    double dpoly = 0.0;
    const double poly = evalPolynomial(a, num_poly, rho, &dpoly);
    if (!(rho * dpoly - poly > 0.0)) {
      return "'a': the ray angle of the direct polynomial must grow with the sensor radius; it "
             "stops at rho = " +
             fmt(rho) + " px, within 10% of the image";
    }
  }
  return {};
}

double ScaramuzzaModel::maxIncidenceAngle(const double* params, int width, int height) const {
  const double c = params[2], d = params[3], e = params[4];
  const double det = c - d * e;
  const double* a = params + 5;
  const auto angle = [&](double rho) {
    return std::atan2(rho, -evalPolynomial(a, num_poly, rho, nullptr));
  };
  // d angle / d rho = (rho poly' - poly) / (rho^2 + poly^2)
  const auto rate = [&](double rho) {
    double dpoly = 0.0;
    const double poly = evalPolynomial(a, num_poly, rho, &dpoly);
    return (rho * dpoly - poly) / (rho * rho + poly * poly);
  };
  double cover_rho = 0.0, cover_angle = 0.0;
  for (const Eigen::Vector2d& pixel : borderPixels(width, height)) {
    const double dr = pixel.y() - params[1], dc = pixel.x() - params[0];
    const double rho = std::hypot((dr - d * dc) / det, (c * dc - e * dr) / det);
    cover_rho = std::max(cover_rho, rho);
    cover_angle = std::max(cover_angle, angle(rho));
  }
  const double limit = kPi - kLimitMargin;
  const double target = std::min(limit, kCoverMargin * cover_angle);
  const double threshold = kMinJacobianRatio * rate(0.0);
  const double step = std::max(cover_rho, 1.0) / 2000.0;
  double good = 0.0;
  for (int k = 1; k <= 100000; ++k) {
    const double rho = k * step;
    if (!(rate(rho) > threshold)) {
      double bad = rho;
      for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (good + bad);
        (rate(mid) > threshold ? good : bad) = mid;
      }
      const double fold_angle = std::min(limit, angle(good));
      return good >= cover_rho ? std::min(target, fold_angle) : fold_angle;
    }
    good = rho;
    const double theta = angle(rho);
    if (theta >= limit) return limit;
    if (rho >= cover_rho && theta >= target) return target;
  }
  return std::min(limit, angle(good));
}

// ---------------------------------------------------------------- Camera

std::string cameraModelName(const CameraModel& model) {
  return std::visit([](const auto& m) { return std::string(m.kName); }, model);
}

CameraModelId cameraModelId(const CameraModel& model) {
  return std::visit([](const auto& m) { return m.kId; }, model);
}

namespace {

/// maxIncidenceAngle scans the model (milliseconds per camera), and a run
/// makes the same calibrations many times (each pass over a dataset reads
/// its manifest): the result is kept by model, size and parameters, up to
/// kMaxCached of them (a fit that tries many parameters starts afresh).
double cachedMaxIncidenceAngle(const CameraModel& model, int width, int height,
                               const std::vector<double>& params) {
  constexpr std::size_t kMaxCached = 1024;
  const auto* scaramuzza = std::get_if<ScaramuzzaModel>(&model);
  using Key = std::tuple<int, int, int, int, std::vector<double>>;
  Key key{static_cast<int>(cameraModelId(model)), width, height,
          scaramuzza ? scaramuzza->num_poly : 0, params};
  static std::mutex mutex;
  static std::map<Key, double> cache;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    if (const auto found = cache.find(key); found != cache.end()) return found->second;
  }
  const double angle = std::visit(
      [&](const auto& m) { return m.maxIncidenceAngle(params.data(), width, height); }, model);
  const std::lock_guard<std::mutex> lock(mutex);
  if (cache.size() >= kMaxCached) cache.clear();
  cache.emplace(std::move(key), angle);
  return angle;
}

}  // namespace

Camera::Camera(CameraModel model, int width, int height, std::vector<double> params)
    : model_(std::move(model)), width_(width), height_(height), params_(std::move(params)) {
  const std::string message = validate(model_, width_, height_, params_);
  if (!message.empty()) throw Error(message);
  max_incidence_angle_ = cachedMaxIncidenceAngle(model_, width_, height_, params_);
}

std::string Camera::validate(const CameraModel& model, int width, int height,
                             const std::vector<double>& params) {
  if (width <= 0) return "'width': must be positive, got " + std::to_string(width);
  if (height <= 0) return "'height': must be positive, got " + std::to_string(height);
  if (const auto* scaramuzza = std::get_if<ScaramuzzaModel>(&model)) {
    if (scaramuzza->num_poly < 2 || scaramuzza->num_inv_poly < 0) {
      return scaramuzza->validate(params.data(), width, height);
    }
  }
  return std::visit(
      [&](const auto& m) -> std::string {
        const std::vector<std::string> names = m.paramNames();
        if (params.size() != names.size()) {
          std::string list;
          for (const std::string& name : names) list += (list.empty() ? "" : " ") + name;
          return "'params': " + std::string(m.kName) + " needs " + std::to_string(names.size()) +
                 " parameters (" + list + "), got " + std::to_string(params.size());
        }
        for (std::size_t i = 0; i < params.size(); ++i) {
          if (!std::isfinite(params[i])) {
            return "'" + names[i] + "': must be finite, got " + fmt(params[i]);
          }
        }
        return m.validate(params.data(), width, height);
      },
      model);
}

std::vector<std::string> Camera::paramNames() const {
  return std::visit([](const auto& m) { return m.paramNames(); }, model_);
}

std::optional<Eigen::Vector2d> Camera::project(const Eigen::Vector3d& p_in_camera) const {
  if (!p_in_camera.allFinite()) return std::nullopt;
  if (!(incidenceAngle(p_in_camera.data()) <= max_incidence_angle_ + kProjectSlack)) {
    return std::nullopt;
  }
  Eigen::Vector2d pixel;
  const bool ok = std::visit(
      [&](const auto& m) { return m.project(params_.data(), p_in_camera.data(), pixel.data()); },
      model_);
  if (!ok || !pixel.allFinite()) return std::nullopt;
  return pixel;
}

std::optional<Eigen::Vector3d> Camera::unproject(const Eigen::Vector2d& pixel) const {
  if (!pixel.allFinite()) return std::nullopt;
  Eigen::Vector3d bearing;
  const bool ok = std::visit(
      [&](const auto& m) { return m.unproject(params_.data(), pixel.data(), bearing.data()); },
      model_);
  if (!ok || !bearing.allFinite()) return std::nullopt;
  if (!(incidenceAngle(bearing.data()) <= max_incidence_angle_ + kUnprojectSlack)) {
    return std::nullopt;
  }
  return bearing;
}

bool Camera::isInImage(const Eigen::Vector2d& pixel, double margin) const {
  return pixel.x() >= -0.5 + margin && pixel.x() <= width_ - 0.5 - margin &&
         pixel.y() >= -0.5 + margin && pixel.y() <= height_ - 0.5 - margin;
}

double Camera::fieldOfView() const {
  const std::optional<Eigen::Vector2d> centre = project(Eigen::Vector3d::UnitZ());
  if (!centre) return 0.0;
  const Eigen::Vector2d lo(-0.5, -0.5), hi(width_ - 0.5, height_ - 0.5);
  // Angle to the axis of the farthest valid point from `inner` towards `outer`.
  const auto reach = [&](const Eigen::Vector2d& inner,
                         const Eigen::Vector2d& outer) -> std::optional<Eigen::Vector3d> {
    if (auto bearing = unproject(outer)) return bearing;
    std::optional<Eigen::Vector3d> best = unproject(inner);
    if (!best) return std::nullopt;
    double good = 0.0, bad = 1.0;
    for (int i = 0; i < 50; ++i) {
      const double mid = 0.5 * (good + bad);
      if (auto bearing = unproject(inner + mid * (outer - inner))) {
        good = mid;
        best = bearing;
      } else {
        bad = mid;
      }
    }
    return best;
  };
  double fov = 0.0;
  for (int axis = 0; axis < 2; ++axis) {
    Eigen::Vector2d inner = centre->cwiseMax(lo).cwiseMin(hi);
    Eigen::Vector2d first = inner, second = inner;
    first[axis] = lo[axis];
    second[axis] = hi[axis];
    const auto b1 = reach(inner, first);
    const auto b2 = reach(inner, second);
    if (!b1 || !b2) continue;
    const bool centre_inside = (*centre)[axis] >= lo[axis] && (*centre)[axis] <= hi[axis];
    const double extent = centre_inside ? incidenceAngle(b1->data()) + incidenceAngle(b2->data())
                                        : std::atan2(b1->cross(*b2).norm(), b1->dot(*b2));
    fov = std::max(fov, extent);
  }
  return fov;
}

std::string Camera::description() const {
  return modelName() + " " + std::to_string(width_) + "x" + std::to_string(height_) + " fov " +
         formatFixed(fieldOfView() * 180.0 / kPi, 1) + " deg";
}

}  // namespace lookboth
