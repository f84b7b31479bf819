// A registration re-expressed in a frame the site uses (`lookboth align`;
// doc/formats.md, "Site frame"):
//   floor   z normal to the plane the robot drove on (fitted to its
//           trajectory, at the fisheye's height), origin at the first pose
//           on that plane, x along the fisheye's x axis there;
//   site    the frame of surveyed control points: camera positions measured
//           with a total station or read off the floor plan, each with its
//           sigma; a weighted rigid alignment whose uncertainty is carried
//           into every camera's covariance.
// The registration's own frame is the first fisheye pose of its trajectory:
// tilted by the robot's stance, different on every drive.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/geometry/sim3.h"
#include "lookboth/registration/registration.h"

namespace lookboth {

struct FloorFit {
  Rigid3d floor_from_world;   ///< The floor frame from the registration's.
  double tilt_deg = 0;        ///< Between the registration's z axis and the floor's normal.
  double flatness_rms_m = 0;  ///< RMS distance of the trajectory's positions from the plane.
  double flatness_max_m = 0;  ///< Their largest distance.
  std::size_t poses = 0;      ///< Trajectory positions fitted.
};

/// The floor plane of a registration's trajectory (total least squares over
/// its positions), its normal towards the cameras. Throws lookboth::Error
/// when the trajectory has fewer than 3 poses or is (nearly) a straight
/// line: the floor's tilt about that line is then not determined.
FloorFit fitFloor(const Registration& registration);

/// A surveyed point in the site's frame: a camera's position, a point the
/// robot's trajectory passed (its dock): the fisheye's optical centre at the
/// start of the drive ("@start"), at its end ("@end") or at a time ("@<unix
/// seconds>", the robot's clock), or the centre of a marker fixed in the
/// facility that the cameras detected ("marker:<id>", located by
/// calib's locateFixedMarkers).
struct ControlPoint {
  std::string name;  ///< The camera's label, "@start", "@end", "@<seconds>" or "marker:<id>".
  Eigen::Vector3d p_in_site;  ///< [m]
  double sigma_m = 0;         ///< Standard deviation of each coordinate [m].
  int line = 0;               ///< In its file, for messages.
};

/// Reads a CSV with the header `name,x,y,z,sigma_m` (metres; '#' comments).
/// Errors name the file, the line and the column.
std::vector<ControlPoint> readControlPoints(const std::filesystem::path& path);

/// A point the registration locates besides its cameras and its trajectory
/// (a fixed marker, "marker:<id>"): where, and how well [m, m^2].
struct LocatedPoint {
  Eigen::Vector3d p_in_world = Eigen::Vector3d::Zero();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  int detections = 0;  ///< Detections it was located from.
};
/// By control-point name ("marker:7").
using LocatedPoints = std::map<std::string, LocatedPoint>;

/// "marker:<id>" for a fixed marker's id.
std::string fixedMarkerPointName(int id);
/// True when a control point's name is a fixed marker's ("marker:...").
bool namesFixedMarker(const std::string& name);

struct ControlPointResidual {
  std::string name;
  Eigen::Vector3d residual_m = Eigen::Vector3d::Zero();  ///< Surveyed - aligned registration.
  double normalized = 0;  ///< |residual| over its predicted sigma (point's and camera's).
};

using Matrix7d = Eigen::Matrix<double, 7, 7>;

struct SiteAlignment {
  Rigid3d site_from_world;  ///< Its rotation and translation (with the scale below: a Sim(3)).
  double scale = 1;  ///< site_from_world's scale (1 unless SiteAlignmentOptions::with_scale).
  /// Of site_from_world over [dt (m); dtheta (rad); ds], a perturbation in
  /// the site frame: p_true = (1 + ds) Exp(dtheta) q + dt, q the aligned
  /// point; ds's row and column are zero for a rigid alignment.
  Matrix7d covariance = Matrix7d::Zero();
  std::vector<ControlPointResidual> residuals;
  double rms_m = 0;
};

/// Options of alignToControlPoints.
struct SiteAlignmentOptions {
  /// A point whose distance from where the other points put it exceeds
  /// this many of its predicted sigmas is an error naming it (3-D: 4.03 is
  /// chi-square 3 dof at 99.9 %). Needs 4 points or more to tell.
  double max_normalized_residual = 4.03;
  /// A similarity (Sim(3)): the scale too, for a registration whose scale the
  /// control points should set (visual mode). Needs 4 points or more.
  bool with_scale = false;
  std::string check() const;
};

/// The weighted rigid (or, with_scale, similarity) alignment of the
/// registration's points to the control points: the registered cameras'
/// positions, the trajectory's and the `located` fixed markers' (weights
/// 1 / (sigma^2 + the point's own position variance, the mean of its
/// covariance's diagonal; a trajectory point's is not recorded: its sigma
/// alone)). `source` names the points' file in messages. Throws
/// lookboth::Error for fewer than 3 usable points (4 with the scale), a
/// point naming no registered camera, no time of the trajectory or no
/// located marker, or an inconsistent point (which one, and by how much).
SiteAlignment alignToControlPoints(const Registration& registration,
                                   const std::vector<ControlPoint>& points,
                                   const std::string& source,
                                   const SiteAlignmentOptions& options = {},
                                   const LocatedPoints& located = {});

/// `registration` with every pose (cameras, their stage poses, the
/// trajectory) mapped by `new_from_world` (a similarity: positions scaled,
/// poses' rotations turned), the covariances rotated (and scaled) with it
/// and, when `transform_covariance` is given (over [dt; dtheta; ds], as
/// SiteAlignment::covariance), that uncertainty added to each camera's.
Registration reexpressRegistration(const Registration& registration, const Sim3d& new_from_world,
                                   const std::optional<Matrix7d>& transform_covariance,
                                   WorldFrame frame);
/// The same for a rigid transform.
Registration reexpressRegistration(const Registration& registration, const Rigid3d& new_from_world,
                                   const std::optional<Matrix7d>& transform_covariance,
                                   WorldFrame frame);

/// A registration re-expressed, with what a person should read about it
/// (one line each: the fit, the residuals per point), for the command line
/// and the desktop app alike.
struct AlignedRegistration {
  Registration registration;
  std::vector<std::string> summary;
};

/// The registration in its floor frame (fitFloor).
AlignedRegistration alignRegistrationToFloor(const Registration& registration);

/// The registration in the frame of the control points in `path`
/// (readControlPoints, alignToControlPoints), the alignment's covariance
/// added to every camera's.
AlignedRegistration alignRegistrationToControlPoints(const Registration& registration,
                                                     const std::filesystem::path& path,
                                                     const SiteAlignmentOptions& options = {},
                                                     const LocatedPoints& located = {});

}  // namespace lookboth
