// Floor and site frames of a registration (site_frame.h).
#include "lookboth/registration/site_frame.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/time.h"
#include "lookboth/geometry/trajectory.h"
#include "lookboth/geometry/umeyama.h"

namespace lookboth {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

/// The unit normal of the plane through `points` (total least squares), the
/// centroid, and the two other eigenvalues of the scatter [m^2].
struct PlaneFit {
  Eigen::Vector3d normal, centroid;
  double middle_variance = 0;
};

PlaneFit fitPlane(const std::vector<Eigen::Vector3d>& points) {
  PlaneFit fit;
  fit.centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) fit.centroid += p;
  fit.centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) {
    scatter += (p - fit.centroid) * (p - fit.centroid).transpose();
  }
  scatter /= static_cast<double>(points.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  fit.normal = eigen.eigenvectors().col(0);  // ascending eigenvalues
  fit.middle_variance = eigen.eigenvalues()(1);
  return fit;
}

}  // namespace

FloorFit fitFloor(const Registration& reg) {
  std::vector<Eigen::Vector3d> points;
  for (const StampedPose& pose : reg.trajectory) points.push_back(pose.world_from_body.translation);
  if (points.size() < 3) {
    throw Error("floor: the registration's trajectory has " + std::to_string(points.size()) +
                " poses; the floor's plane needs at least 3");
  }
  const PlaneFit plane = fitPlane(points);
  // A drive narrower than 0.25 m (RMS) across: the tilt about its line is
  // not determined by it.
  if (plane.middle_variance < 0.25 * 0.25) {
    throw Error("floor: the trajectory is (nearly) a straight line (" +
                formatFixed(std::sqrt(plane.middle_variance), 3) +
                " m RMS across it); the floor's tilt about that line is not determined. "
                "Drive a turn, or use control points (--control-points)");
  }
  // The normal points to the cameras' side (up), or the registration's z.
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d towards_cameras = Eigen::Vector3d::Zero();
  for (const CameraRegistration& c : reg.cameras) {
    if (c.status != CameraStatus::kUnregistered) {
      towards_cameras += c.world_from_camera.translation - plane.centroid;
    }
  }
  if (towards_cameras.norm() > 0) up = towards_cameras;
  const Eigen::Vector3d z = plane.normal.dot(up) >= 0 ? plane.normal : -plane.normal;
  // Origin: the first pose on the plane; x: the fisheye's x axis there, on the plane.
  const Rigid3d& first = reg.trajectory.front().world_from_body;
  const Eigen::Vector3d origin = first.translation - z * z.dot(first.translation - plane.centroid);
  Eigen::Vector3d x = first.rotation * Eigen::Vector3d::UnitX();
  x -= z * z.dot(x);
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX() - z * z.x();  // fisheye x along the normal
  x.normalize();
  Eigen::Matrix3d world_from_floor_rotation;
  world_from_floor_rotation << x, z.cross(x), z;
  const Rigid3d world_from_floor(Eigen::Quaterniond(world_from_floor_rotation), origin);

  FloorFit fit;
  fit.floor_from_world = world_from_floor.inverse();
  fit.tilt_deg = std::acos(std::clamp(z.z(), -1.0, 1.0)) * kRadToDeg;
  fit.poses = points.size();
  double squares = 0;
  for (const Eigen::Vector3d& p : points) {
    const double d = std::abs(z.dot(p - plane.centroid));
    squares += d * d;
    fit.flatness_max_m = std::max(fit.flatness_max_m, d);
  }
  fit.flatness_rms_m = std::sqrt(squares / static_cast<double>(points.size()));
  return fit;
}

namespace {

std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::istringstream in(line);
  for (std::string field; std::getline(in, field, ',');) {
    const auto first = field.find_first_not_of(" \t\r");
    const auto last = field.find_last_not_of(" \t\r");
    fields.push_back(first == std::string::npos ? "" : field.substr(first, last - first + 1));
  }
  return fields;
}

ControlPoint controlPointFrom(const std::vector<std::string>& fields,
                              const std::map<std::string, std::size_t>& column,
                              const std::string& file, int line) {
  ControlPoint point;
  point.line = line;
  point.name = fields[column.at("name")];
  if (point.name.empty()) throw Error({file, line, "name", ""}, "empty name");
  double values[4];
  const char* names[4] = {"x", "y", "z", "sigma_m"};
  for (int i = 0; i < 4; ++i) {
    const std::string& text = fields[column.at(names[i])];
    const std::optional<double> v = parseDouble(text);
    if (!v || !std::isfinite(*v)) {
      throw Error({file, line, names[i], ""}, "not a number: '" + excerpt(text) + "'");
    }
    values[i] = *v;
  }
  if (values[3] <= 0) {
    throw Error({file, line, "sigma_m", ""}, "must be positive (the point's standard deviation)");
  }
  point.p_in_site = Eigen::Vector3d(values[0], values[1], values[2]);
  point.sigma_m = values[3];
  return point;
}

}  // namespace

std::vector<ControlPoint> readControlPoints(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw Error({path.string(), 0, "", ""}, "cannot open for reading");
  const std::string file = path.string();
  std::map<std::string, std::size_t> column;
  std::vector<ControlPoint> points;
  std::map<std::string, int> seen;
  int line_number = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_number;
    if (line_number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // UTF-8 BOM
    const auto start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    const std::vector<std::string> fields = splitFields(line);
    if (column.empty()) {
      for (std::size_t i = 0; i < fields.size(); ++i) column[fields[i]] = i;
      for (const char* name : {"name", "x", "y", "z", "sigma_m"}) {
        if (!column.count(name)) {
          throw Error({file, line_number, name, ""},
                      "required column is missing from the header (expected "
                      "'name,x,y,z,sigma_m')");
        }
      }
      continue;
    }
    if (fields.size() < column.size()) {
      throw Error({file, line_number, "", ""}, "expected " + std::to_string(column.size()) +
                                                   " fields, got " + std::to_string(fields.size()));
    }
    ControlPoint point = controlPointFrom(fields, column, file, line_number);
    if (const auto it = seen.find(point.name); it != seen.end()) {
      throw Error({file, line_number, "name", ""},
                  "'" + point.name + "' is already on line " + std::to_string(it->second));
    }
    seen[point.name] = line_number;
    points.push_back(std::move(point));
  }
  if (column.empty())
    throw Error({file, 0, "", ""}, "empty: expected the header 'name,x,y,z,sigma_m'");
  return points;
}

std::string SiteAlignmentOptions::check() const {
  if (!(max_normalized_residual > 0)) return "max_normalized_residual: must be positive";
  return "";
}

namespace {

/// A control point with the registration's point it names.
struct Pair {
  const ControlPoint* point;
  Eigen::Vector3d p_in_world;
  double variance;  ///< Per coordinate: the point's and the camera's position's.
};

/// The fisheye's position when the trajectory passed a control point named
/// "@start", "@end" or "@<seconds>".
Eigen::Vector3d trajectoryPoint(const Registration& reg, const ControlPoint& point,
                                const std::string& source) {
  if (reg.trajectory.empty()) {
    throw Error({source, point.line, "name", ""},
                "'" + point.name + "': the registration has no trajectory");
  }
  const std::string when = point.name.substr(1);
  if (when == "start") return reg.trajectory.front().world_from_body.translation;
  if (when == "end") return reg.trajectory.back().world_from_body.translation;
  const std::optional<TimeNs> t = parseSeconds(when);
  if (!t) {
    throw Error({source, point.line, "name", ""},
                "'" + point.name + "': expected @start, @end or @<unix seconds>");
  }
  const Trajectory trajectory(reg.trajectory);
  const InterpolationResult pose =
      trajectory.interpolate(*t, effectiveMaxGap(trajectory, 500'000'000));
  if (!pose.ok()) {
    throw Error({source, point.line, "name", ""},
                "'" + point.name + "': the trajectory has no pose then (it runs from " +
                    formatSeconds(reg.trajectory.front().t) + " to " +
                    formatSeconds(reg.trajectory.back().t) + " s)");
  }
  return pose.world_from_body.translation;
}

Pair locatedPair(const ControlPoint& point, const LocatedPoints& located,
                 const std::string& source) {
  const auto found = located.find(point.name);
  if (found == located.end()) {
    throw Error({source, point.line, "name", ""},
                "'" + point.name +
                    "': no registered camera detected that marker (its id is in the "
                    "dataset's detections only when a camera saw it; check the id)");
  }
  const double variance = found->second.covariance.trace() / 3;
  return {&point, found->second.p_in_world, point.sigma_m * point.sigma_m + variance};
}

std::vector<Pair> pairUp(const Registration& reg, const std::vector<ControlPoint>& points,
                         const std::string& source, std::size_t minimum,
                         const LocatedPoints& located) {
  std::vector<Pair> pairs;
  for (const ControlPoint& point : points) {
    const double sigma2 = point.sigma_m * point.sigma_m;
    if (!point.name.empty() && point.name[0] == '@') {
      pairs.push_back({&point, trajectoryPoint(reg, point, source), sigma2});
      continue;
    }
    if (namesFixedMarker(point.name)) {
      pairs.push_back(locatedPair(point, located, source));
      continue;
    }
    const CameraRegistration* camera = reg.findCamera(point.name);
    if (camera == nullptr || camera->status == CameraStatus::kUnregistered) {
      throw Error({source, point.line, "name", ""},
                  "'" + point.name + "' is not a registered camera of this registration");
    }
    double camera_variance = 0;
    if (camera->covariance) camera_variance = camera->covariance->topLeftCorner<3, 3>().trace() / 3;
    pairs.push_back({&point, camera->world_from_camera.translation, sigma2 + camera_variance});
  }
  if (pairs.size() < minimum) {
    throw Error({source, 0, "", ""}, "the site frame needs at least " + std::to_string(minimum) +
                                         " control points, got " + std::to_string(pairs.size()));
  }
  return pairs;
}

Sim3d alignPairs(const std::vector<Pair>& pairs, std::size_t skip, bool with_scale,
                 const std::string& source) {
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<double> weights;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (i == skip) continue;
    src.push_back(pairs[i].p_in_world);
    dst.push_back(pairs[i].point->p_in_site);
    weights.push_back(1.0 / pairs[i].variance);
  }
  std::string why;
  const auto aligned =
      with_scale ? alignSim3(src, dst, weights, &why) : alignRigid3(src, dst, weights, &why);
  if (!aligned) throw Error({source, 0, "", ""}, "the control points give no frame: " + why);
  return aligned->dst_from_src;
}

/// How a point's aligned position q moves with the perturbation [dt;
/// dtheta; ds] of site_from_world: [I, -[q]x, q].
Eigen::Matrix<double, 3, 7> alignmentJacobian(const Eigen::Vector3d& q) {
  Eigen::Matrix<double, 3, 7> j;
  j << Eigen::Matrix3d::Identity(), -skew(q), q;
  return j;
}

/// The covariance of site_from_world from the points (all but `skip`):
/// the inverse of their information, over [dt; dtheta] or, with the scale,
/// [dt; dtheta; ds].
Matrix7d alignmentCovariance(const std::vector<Pair>& pairs, const Sim3d& site_from_world,
                             std::size_t skip, bool with_scale) {
  Matrix7d information = Matrix7d::Zero();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    if (i == skip) continue;
    const Eigen::Matrix<double, 3, 7> j = alignmentJacobian(site_from_world * pairs[i].p_in_world);
    information += j.transpose() * j / pairs[i].variance;
  }
  Matrix7d covariance = Matrix7d::Zero();
  if (with_scale) {
    covariance = information.inverse();
  } else {
    covariance.topLeftCorner<6, 6>() = information.topLeftCorner<6, 6>().inverse();
  }
  return covariance;
}

/// The point farthest from where the others put it, in sigmas of that
/// prediction (its own variance and the others' alignment's), chi-square
/// with 3 dof.
void checkConsistency(const std::vector<Pair>& pairs, const std::string& source,
                      const SiteAlignmentOptions& options) {
  if (pairs.size() < (options.with_scale ? 5u : 4u)) return;
  double worst = 0, worst_distance = 0;
  std::size_t worst_index = 0;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const Sim3d others = alignPairs(pairs, i, options.with_scale, source);
    const Eigen::Vector3d q = others * pairs[i].p_in_world;
    const Eigen::Vector3d residual = pairs[i].point->p_in_site - q;
    const Eigen::Matrix<double, 3, 7> j = alignmentJacobian(q);
    const Eigen::Matrix3d predicted =
        Eigen::Matrix3d::Identity() * pairs[i].variance +
        j * alignmentCovariance(pairs, others, i, options.with_scale) * j.transpose();
    const double normalized = std::sqrt(residual.dot(predicted.inverse() * residual));
    if (normalized > worst) {
      worst = normalized;
      worst_index = i;
      worst_distance = residual.norm();
    }
  }
  if (worst > options.max_normalized_residual) {
    const ControlPoint& p = *pairs[worst_index].point;
    throw Error({source, p.line, "", ""},
                "control point '" + p.name + "' is " + formatFixed(worst_distance * 100, 1) +
                    " cm from where the other points put it (" + formatFixed(worst, 1) +
                    " sigmas; its sigma " + formatFixed(p.sigma_m * 100, 1) +
                    " cm): check its coordinates and its label");
  }
}

}  // namespace

std::string fixedMarkerPointName(int id) { return "marker:" + std::to_string(id); }

bool namesFixedMarker(const std::string& name) { return name.rfind("marker:", 0) == 0; }

SiteAlignment alignToControlPoints(const Registration& reg, const std::vector<ControlPoint>& points,
                                   const std::string& source, const SiteAlignmentOptions& options,
                                   const LocatedPoints& located) {
  if (const std::string why = options.check(); !why.empty()) throw Error(why);
  const std::vector<Pair> pairs = pairUp(reg, points, source, options.with_scale ? 4 : 3, located);
  checkConsistency(pairs, source, options);
  SiteAlignment result;
  const Sim3d site_from_world = alignPairs(pairs, pairs.size(), options.with_scale, source);
  result.site_from_world = Rigid3d(site_from_world.rotation, site_from_world.translation);
  result.scale = site_from_world.scale;
  double squares = 0;
  for (const Pair& pair : pairs) {
    const Eigen::Vector3d q = site_from_world * pair.p_in_world;
    ControlPointResidual residual;
    residual.name = pair.point->name;
    residual.residual_m = pair.point->p_in_site - q;
    residual.normalized = residual.residual_m.norm() / std::sqrt(pair.variance);
    squares += residual.residual_m.squaredNorm();
    result.residuals.push_back(residual);
  }
  result.covariance = alignmentCovariance(pairs, site_from_world, pairs.size(), options.with_scale);
  result.rms_m = std::sqrt(squares / static_cast<double>(pairs.size()));
  return result;
}

namespace {

Matrix6d reexpressCovariance(const Matrix6d& covariance, const Sim3d& new_from_world,
                             const Rigid3d& new_pose,
                             const std::optional<Matrix7d>& transform_covariance) {
  // dt' = s R_T dt (+ dt_T - [t']x dtheta_T + t' ds_T); dtheta' = dtheta (+ R'^T dtheta_T).
  Matrix6d a = Matrix6d::Identity();
  a.topLeftCorner<3, 3>() = new_from_world.scale * new_from_world.rotation.toRotationMatrix();
  Matrix6d result = a * covariance * a.transpose();
  if (transform_covariance) {
    Eigen::Matrix<double, 6, 7> b = Eigen::Matrix<double, 6, 7>::Zero();
    b.topLeftCorner<3, 3>() = Eigen::Matrix3d::Identity();
    b.block<3, 3>(0, 3) = -skew(new_pose.translation);
    b.block<3, 1>(0, 6) = new_pose.translation;
    b.block<3, 3>(3, 3) = new_pose.rotation.toRotationMatrix().transpose();
    result += b * *transform_covariance * b.transpose();
  }
  return result;
}

}  // namespace

Registration reexpressRegistration(const Registration& registration, const Sim3d& new_from_world,
                                   const std::optional<Matrix7d>& transform_covariance,
                                   WorldFrame frame) {
  Registration out = registration;
  const Sim3d own(registration.world_frame.scale_from_registration,
                  registration.world_frame.from_registration
                      ? registration.world_frame.from_registration->rotation
                      : Eigen::Quaterniond::Identity(),
                  registration.world_frame.from_registration
                      ? registration.world_frame.from_registration->translation
                      : Eigen::Vector3d::Zero());
  const Sim3d from_registration = new_from_world * own;
  frame.from_registration = Rigid3d(from_registration.rotation, from_registration.translation);
  frame.scale_from_registration = from_registration.scale;
  out.world_frame = std::move(frame);
  const double s = new_from_world.scale;
  const Eigen::Matrix3d rotation = new_from_world.rotation.toRotationMatrix();
  for (CameraRegistration& c : out.cameras) {
    c.world_from_camera = new_from_world.transformPose(c.world_from_camera);
    for (auto& [stage, pose] : c.stage_poses) pose = new_from_world.transformPose(pose);
    if (c.covariance) {
      c.covariance = reexpressCovariance(*c.covariance, new_from_world, c.world_from_camera,
                                         transform_covariance);
    }
    if (c.aligned_position_covariance) {
      c.aligned_position_covariance =
          Eigen::Matrix3d(s * s * rotation * *c.aligned_position_covariance * rotation.transpose());
    }
    if (c.residuals) c.residuals->position_rms_m *= s;
  }
  for (StampedPose& pose : out.trajectory) {
    pose.world_from_body = new_from_world.transformPose(pose.world_from_body);
  }
  if (s != 1) {
    out.scale *= s;
    out.scale_sigma *= s;
    if (out.observability.aligned_position_rmse_m) *out.observability.aligned_position_rmse_m *= s;
  }
  return out;
}

Registration reexpressRegistration(const Registration& registration, const Rigid3d& new_from_world,
                                   const std::optional<Matrix7d>& transform_covariance,
                                   WorldFrame frame) {
  return reexpressRegistration(registration, Sim3d(new_from_world), transform_covariance,
                               std::move(frame));
}

AlignedRegistration alignRegistrationToFloor(const Registration& reg) {
  const FloorFit fit = fitFloor(reg);
  WorldFrame frame;
  frame.name = "floor";
  frame.description = "z normal to the floor the robot drove on (fitted to " +
                      std::to_string(fit.poses) + " trajectory poses; tilt " +
                      formatFixed(fit.tilt_deg, 3) + " deg from the registration's z, flatness " +
                      formatFixed(fit.flatness_rms_m * 1000, 1) + " mm RMS, " +
                      formatFixed(fit.flatness_max_m * 1000, 1) +
                      " mm max), origin at the first pose at the fisheye's height, x along the "
                      "fisheye's x axis there";
  AlignedRegistration aligned{reexpressRegistration(reg, fit.floor_from_world, std::nullopt, frame),
                              {}};
  aligned.summary.push_back("floor: tilt " + formatFixed(fit.tilt_deg, 3) + " deg, flatness " +
                            formatFixed(fit.flatness_rms_m * 1000, 1) + " mm RMS (" +
                            formatFixed(fit.flatness_max_m * 1000, 1) + " mm max) over " +
                            std::to_string(fit.poses) + " poses");
  return aligned;
}

namespace {

std::string padded(const std::string& text, std::size_t width, bool left) {
  if (text.size() >= width) return text;
  const std::string pad(width - text.size(), ' ');
  return left ? text + pad : pad + text;
}

}  // namespace

AlignedRegistration alignRegistrationToControlPoints(const Registration& reg,
                                                     const std::filesystem::path& path,
                                                     const SiteAlignmentOptions& options,
                                                     const LocatedPoints& located) {
  const std::vector<ControlPoint> points = readControlPoints(path);
  const SiteAlignment site = alignToControlPoints(reg, points, path.string(), options, located);
  const std::string scale_text =
      options.with_scale ? ", scale " + formatFixed(site.scale, 6) + " +- " +
                               formatFixed(std::sqrt(site.covariance(6, 6)) * site.scale, 6)
                         : "";
  WorldFrame frame;
  frame.name = "site";
  frame.description = "the frame of the control points in " + path.string() + " (" +
                      std::to_string(points.size()) + " points, RMS residual " +
                      formatFixed(site.rms_m * 1000, 1) + " mm" + scale_text + ")";
  for (std::size_t i = 0; i < site.residuals.size(); ++i) {
    const ControlPointResidual& r = site.residuals[i];
    const auto point = std::find_if(points.begin(), points.end(),
                                    [&](const ControlPoint& p) { return p.name == r.name; });
    frame.control_points.push_back(
        {r.name, point != points.end() ? point->p_in_site : Eigen::Vector3d::Zero().eval(),
         r.residual_m, r.normalized});
  }
  const Sim3d site_from_world(site.scale, site.site_from_world.rotation,
                              site.site_from_world.translation);
  AlignedRegistration aligned{reexpressRegistration(reg, site_from_world, site.covariance, frame),
                              {}};
  std::vector<std::string>& lines = aligned.summary;
  lines.push_back("site: " + std::to_string(points.size()) + " control points, RMS residual " +
                  formatFixed(site.rms_m * 1000, 1) + " mm" + scale_text);
  lines.push_back("  point            dx [mm]   dy [mm]   dz [mm]   sigmas");
  for (const ControlPointResidual& r : site.residuals) {
    std::string line = "  " + padded(r.name, 14, true);
    for (int i = 0; i < 3; ++i) line += padded(formatFixed(r.residual_m[i] * 1000, 1), 10, false);
    lines.push_back(line + padded(formatFixed(r.normalized, 2), 9, false));
  }
  const double sigma = site.covariance.diagonal().head<3>().cwiseSqrt().norm();
  lines.push_back("  the frame's own uncertainty (added to every camera's covariance): " +
                  formatFixed(sigma * 1000, 1) + " mm in position");
  return aligned;
}

}  // namespace lookboth
