#include "lookboth/detect/marker_detector.h"

#include "lookboth/dataset/marker_dictionary.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <opencv2/aruco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <set>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/lie.h"

namespace lookboth {

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Bilinear sample (pixel (0,0) is the centre of the top-left pixel); NaN outside.
double sampleBilinear(const cv::Mat& grey, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
  if (x0 < 0 || y0 < 0 || x0 + 1 >= grey.cols || y0 + 1 >= grey.rows) return std::nan("");
  const double ax = x - fx, ay = y - fy;
  const std::uint8_t* r0 = grey.ptr<std::uint8_t>(y0) + x0;
  const std::uint8_t* r1 = grey.ptr<std::uint8_t>(y0 + 1) + x0;
  return (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// Unit normal of the plane through the origin that best fits the bearings
/// (least squares on n.b); nullopt with fewer than 3 bearings.
std::optional<Eigen::Vector3d> fitPlane(const std::vector<Eigen::Vector3d>& bearings) {
  if (bearings.size() < 3) return std::nullopt;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& b : bearings) scatter += b * b.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  return solver.eigenvectors().col(0).normalized();
}

/// Object points of the square (ArUco order) [m].
std::array<Eigen::Vector3d, 4> squareCorners(double side) {
  const double h = side / 2;
  return {Eigen::Vector3d(-h, h, 0), Eigen::Vector3d(h, h, 0), Eigen::Vector3d(h, -h, 0),
          Eigen::Vector3d(-h, -h, 0)};
}

Rigid3d perturbed(const Rigid3d& pose, const Eigen::Matrix<double, 6, 1>& delta) {
  const Eigen::Vector3d dtheta = delta.tail<3>();
  return Rigid3d((pose.rotation * so3Exp(dtheta)).normalized(), pose.translation + delta.head<3>());
}

/// Pixel residuals of the 4 corners; nullopt when a corner does not project.
std::optional<Eigen::Matrix<double, 8, 1>> residuals(const Camera& camera, const Rigid3d& pose,
                                                     const std::array<Eigen::Vector3d, 4>& object,
                                                     const std::array<Eigen::Vector2d, 4>& px) {
  Eigen::Matrix<double, 8, 1> r;
  for (int k = 0; k < 4; ++k) {
    const auto p = camera.project(pose * object[static_cast<size_t>(k)]);
    if (!p) return std::nullopt;
    r.segment<2>(2 * k) = *p - px[static_cast<size_t>(k)];
  }
  return r;
}

/// d residuals / d [dt; dtheta], central differences.
std::optional<Eigen::Matrix<double, 8, 6>> jacobian(const Camera& camera, const Rigid3d& pose,
                                                    const std::array<Eigen::Vector3d, 4>& object,
                                                    const std::array<Eigen::Vector2d, 4>& px) {
  Eigen::Matrix<double, 8, 6> jac;
  for (int j = 0; j < 6; ++j) {
    const double h = j < 3 ? 1e-6 : 1e-7;
    Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
    delta(j) = h;
    const auto plus = residuals(camera, perturbed(pose, delta), object, px);
    const auto minus = residuals(camera, perturbed(pose, -delta), object, px);
    if (!plus || !minus) return std::nullopt;
    jac.col(j) = (*plus - *minus) / (2 * h);
  }
  return jac;
}

/// OpenCV's predefined dictionary a valid MarkerSpec names; throws
/// lookboth::Error for an invalid spec.
cv::Ptr<cv::aruco::Dictionary> predefinedDictionary(const MarkerSpec& marker) {
  if (const std::string why = marker.check(); !why.empty()) throw Error("marker: " + why);
  return cv::aruco::getPredefinedDictionary(arucoDictionaryId(marker.dictionary));
}

/// The fields readDictionary reads, checked first: it writes each marker's
/// bits into a markersize^2 matrix without checking the string's length.
void checkDictionaryNode(const cv::FileNode& root, const std::string& file) {
  const auto fail = [&file](const std::string& field, const std::string& why) {
    throw Error(ErrorContext{file, 0, field, ""}, why);
  };
  if (!root.isMap())
    fail("", "not an ArUco dictionary (a map of nmarkers, markersize, marker_0...)");
  const cv::FileNode count = root["nmarkers"], side = root["markersize"];
  if (!count.isInt() || static_cast<int>(count) < 1)
    fail("nmarkers", "missing or not a positive integer");
  if (!side.isInt() || static_cast<int>(side) < 1)
    fail("markersize", "missing or not a positive integer (bits per side)");
  const size_t bits =
      static_cast<size_t>(static_cast<int>(side)) * static_cast<size_t>(static_cast<int>(side));
  for (int i = 0; i < static_cast<int>(count); ++i) {
    const std::string key = "marker_" + std::to_string(i);
    const cv::FileNode marker = root[key];
    if (!marker.isString()) fail(key, "missing or not a string of bits");
    const std::string value = marker.string();
    if (value.size() != bits || value.find_first_not_of("01") != std::string::npos)
      fail(key, "not a string of " + std::to_string(bits) + " '0'/'1' bits (markersize^2)");
  }
}

/// A custom dictionary from an OpenCV FileStorage file; throws lookboth::Error naming the file.
cv::Ptr<cv::aruco::Dictionary> readDictionaryFile(const std::filesystem::path& path) {
  const std::string file = path.string();
  if (!std::filesystem::is_regular_file(path)) {
    throw Error(ErrorContext{file, 0, "", ""},
                std::string("cannot open the ArUco dictionary file: ") +
                    (std::filesystem::exists(path) ? "not a regular file" : "no such file"));
  }
  cv::FileStorage storage;
  try {
    if (!storage.open(file, cv::FileStorage::READ))
      throw Error(ErrorContext{file, 0, "", ""}, "cannot open the ArUco dictionary file");
    checkDictionaryNode(storage.root(), file);
    auto dictionary = cv::makePtr<cv::aruco::Dictionary>();
    if (!dictionary->readDictionary(storage.root()))
      throw Error(ErrorContext{file, 0, "", ""}, "OpenCV cannot read it as an ArUco dictionary");
    return dictionary;
  } catch (const cv::Exception& e) {
    // OpenCV 4.6 puts a parse error's "file(line): reason" in `func`, the parser's name in `err`.
    const std::string why = e.code == cv::Error::StsParseError ? e.func : e.err;
    throw Error(ErrorContext{file, 0, "", ""},
                "OpenCV cannot read it as an ArUco dictionary (" + why + ")");
  }
}

}  // namespace

std::optional<int> parseFixedMarkerId(const std::string& key) {
  int id = -1;
  const auto [end, error] = std::from_chars(key.data(), key.data() + key.size(), id);
  if (error != std::errc() || end != key.data() + key.size() || id < 0) return std::nullopt;
  return id;
}

std::string MarkerDetectorOptions::check() const {
  if (detect_scale < 0 || detect_scale > 8)
    return "'detect_scale': must be in [0, 8] (0 = automatic), got " + std::to_string(detect_scale);
  if (!(roi_margin > 0)) return "'roi_margin': must be positive";
  if (!(corner_sigma_px > 0)) return "'corner_sigma_px': must be positive";
  if (!(min_corner_sigma_px > 0)) return "'min_corner_sigma_px': must be positive";
  if (!(fallback_corner_sigma_px > 0)) return "'fallback_corner_sigma_px': must be positive";
  if (!(min_side_px >= 4)) return "'min_side_px': must be at least 4";
  if (!(max_reprojection_px > 0)) return "'max_reprojection_px': must be positive";
  if (!(ambiguity_ratio >= 1)) return "'ambiguity_ratio': must be at least 1";
  if (!(max_speed_mps >= 0)) return "'max_speed_mps': must be >= 0";
  if (!(track_window_s > 0)) return "'track_window_s': must be positive";
  if (!(coarse_period_s >= 0) || coarse_period_s > 60)
    return "'coarse_period_s': must be between 0 (every frame) and 60 s";
  if (!(coarse_key_frames_max_s >= 0) || coarse_key_frames_max_s > 60)
    return "'coarse_key_frames_max_s': must be between 0 (never) and 60 s";
  if (!(coarse_change_grey >= 0) || coarse_change_grey > 100)
    return "'coarse_change_grey': must be between 0 (search every coarse frame) and 100";
  if (!(coarse_change_max_s >= 0) || coarse_change_max_s > 3600)
    return "'coarse_change_max_s': must be between 0 and 3600 s";
  std::set<int> fixed_ids;
  for (const auto& [id, size] : fixed_marker_sizes_m) {
    const std::optional<int> number = parseFixedMarkerId(id);
    if (!number) return "'fixed_marker_sizes_m': '" + id + "' is not a marker id (0 or more)";
    if (!fixed_ids.insert(*number).second) {
      return "'fixed_marker_sizes_m': marker " + std::to_string(*number) + " is listed twice";
    }
    if (!(size > 0) || size > 5) {
      return "'fixed_marker_sizes_m': marker " + id + "'s side must be in (0, 5] m";
    }
  }
  if (fixed_marker_frames < 1 || fixed_marker_frames > 10000)
    return "'fixed_marker_frames': must be between 1 and 10000";
  return "";
}

struct MarkerDetector::Impl {
  Impl(const Camera& camera_, cv::Ptr<cv::aruco::Dictionary> dictionary_, int id_)
      : camera(camera_), dictionary(std::move(dictionary_)), id(id_) {}
  Camera camera;
  cv::Ptr<cv::aruco::Dictionary> dictionary;
  int id = 0;  ///< The marker's index in the dictionary.
  cv::Ptr<cv::aruco::DetectorParameters> parameters;
  int cells = 6;  ///< Marker side in cells, including the black border.
  std::array<Eigen::Vector3d, 4> object;
  std::optional<cv::Rect> last_box;  ///< Bounding box of the last detection [px].
  int scale = 1;
};

MarkerDetector::MarkerDetector(const MarkerSpec& marker, const Camera& camera,
                               const MarkerDetectorOptions& options)
    : MarkerDetector(std::make_unique<Impl>(camera, predefinedDictionary(marker), marker.id),
                     marker.size_m, options) {}

MarkerDetector MarkerDetector::withDictionaryFile(const std::filesystem::path& dictionary_file,
                                                  int id, double size_m, const Camera& camera,
                                                  const MarkerDetectorOptions& options) {
  cv::Ptr<cv::aruco::Dictionary> dictionary = readDictionaryFile(dictionary_file);
  const int count = dictionary->bytesList.rows;
  if (id < 0 || id >= count) {
    throw Error(ErrorContext{dictionary_file.string(), 0, "id", ""},
                std::to_string(id) + " is not in this dictionary (ids 0.." +
                    std::to_string(count - 1) + ")");
  }
  if (!(size_m > 0) || !std::isfinite(size_m)) {
    throw Error("marker: 'size_m': must be a positive length in metres, got " +
                formatDouble(size_m));
  }
  return MarkerDetector(std::make_unique<Impl>(camera, std::move(dictionary), id), size_m, options);
}

MarkerDetector::MarkerDetector(std::unique_ptr<Impl> impl, double size_m,
                               const MarkerDetectorOptions& options)
    : impl_(std::move(impl)), options_(options) {
  if (const std::string why = options.check(); !why.empty()) throw Error("detect.markers: " + why);
  impl_->cells = impl_->dictionary->markerSize + 2;
  impl_->parameters = cv::aruco::DetectorParameters::create();
  impl_->parameters->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
  impl_->object = squareCorners(size_m);
  impl_->scale =
      options.detect_scale > 0 ? options.detect_scale : (impl_->camera.width() > 1280 ? 2 : 1);
}

MarkerDetector::~MarkerDetector() = default;
MarkerDetector::MarkerDetector(MarkerDetector&&) noexcept = default;

void MarkerDetector::resetTrack() { impl_->last_box.reset(); }

std::optional<std::array<Eigen::Vector2d, 4>> MarkerDetector::refineCorners(
    const cv::Mat& grey, const std::array<Eigen::Vector2d, 4>& initial, double* corner_sigma_px,
    std::string* why_not) const {
  const auto fail = [why_not](const char* why) -> std::optional<std::array<Eigen::Vector2d, 4>> {
    if (why_not) *why_not = why;
    return std::nullopt;
  };
  double variance_sum = 0;  // of the corners' positions along each edge's normal [px^2]
  const Camera& camera = impl_->camera;
  std::array<Eigen::Vector2d, 4> corners = initial;
  for (int iteration = 0; iteration < 2; ++iteration) {
    variance_sum = 0;
    std::array<Eigen::Vector3d, 4> corner_bearings;
    for (size_t k = 0; k < 4; ++k) {
      const auto b = camera.unproject(corners[k]);
      if (!b) return fail("a corner outside the camera model's field of view");
      corner_bearings[k] = *b;
    }
    const Eigen::Vector2d centre = 0.25 * (corners[0] + corners[1] + corners[2] + corners[3]);
    std::array<Eigen::Vector3d, 4> planes;
    for (size_t k = 0; k < 4; ++k) {
      const size_t k1 = (k + 1) % 4;
      const double length = (corners[k1] - corners[k]).norm();
      // The profile must stay inside the black border cell, whose width
      // across this edge is the adjacent sides' length over the cells.
      const double across = 0.5 * ((corners[k] - corners[(k + 3) % 4]).norm() +
                                   (corners[(k + 2) % 4] - corners[k1]).norm());
      const double cell = across / impl_->cells;
      // Inside: within the border cell; outside: the white quiet zone (at
      // least a cell wide on a proper marker; the simulator's is 1.2 cells).
      const double inner = std::clamp(0.6 * cell, 1.5, 8.0);
      const double outer = std::clamp(0.8 * cell, 1.5, 8.0);
      const double step = 0.5;
      const int samples = std::max(6, static_cast<int>(length / 1.5));
      struct Profile {
        Eigen::Vector2d at, normal;
        std::vector<double> values;
      };
      std::vector<Profile> profiles;
      std::vector<double> blacks, whites;
      const int steps = static_cast<int>(std::round((inner + outer) / step));
      for (int i = 0; i < samples; ++i) {
        const double s = 0.15 + 0.7 * (i + 0.5) / samples;
        const Eigen::Vector3d b0 = ((1 - s) * corner_bearings[k] + s * corner_bearings[k1]);
        const double ds = 1e-3;
        const Eigen::Vector3d b1 =
            ((1 - s - ds) * corner_bearings[k] + (s + ds) * corner_bearings[k1]);
        const auto p0 = camera.project(b0), p1 = camera.project(b1);
        if (!p0 || !p1) continue;
        const Eigen::Vector2d tangent = (*p1 - *p0).normalized();
        Eigen::Vector2d normal(-tangent.y(), tangent.x());
        if (normal.dot(*p0 - centre) < 0) normal = -normal;  // outward: black -> white
        Profile profile{*p0, normal, {}};
        bool inside = true;
        for (int j = 0; j <= steps && inside; ++j) {
          const Eigen::Vector2d q = *p0 + (-inner + j * step) * normal;
          const double value = sampleBilinear(grey, q.x(), q.y());
          inside = !std::isnan(value);
          profile.values.push_back(value);
        }
        if (!inside) continue;
        blacks.push_back(0.5 * (profile.values[0] + profile.values[1]));
        whites.push_back(0.5 * (profile.values[profile.values.size() - 1] +
                                profile.values[profile.values.size() - 2]));
        profiles.push_back(std::move(profile));
      }
      if (profiles.size() < 3) return fail("an edge at the frame's border");
      const double black = median(blacks), white = median(whites);
      if (white - black < 20) return fail("an edge of low contrast (under 20 grey levels)");
      std::vector<Eigen::Vector3d> edge_bearings;
      for (const Profile& profile : profiles) {
        // Area of the "black fraction" across the window = distance of the
        // edge from the window's start (a blurred step integrates to it).
        double area = 0;
        for (const double value : profile.values) {
          area += std::clamp((white - value) / (white - black), -0.5, 1.5) * step;
        }
        const double offset = area - inner - step / 2;
        if (offset < -inner + 0.5 || offset > outer - 0.5) continue;
        const auto b = camera.unproject(profile.at + offset * profile.normal);
        if (b) edge_bearings.push_back(*b);
      }
      auto plane = fitPlane(edge_bearings);
      if (!plane) return fail("an edge not found within its border cell (no quiet zone?)");
      // One pass of outlier rejection (e.g. a sample that met a bit cell).
      std::vector<double> distances;
      for (const Eigen::Vector3d& b : edge_bearings) distances.push_back(std::abs(plane->dot(b)));
      const double limit = 3.0 * std::max(median(distances), 1e-9);
      std::vector<Eigen::Vector3d> kept;
      for (const Eigen::Vector3d& b : edge_bearings)
        if (std::abs(plane->dot(b)) <= limit) kept.push_back(b);
      if (kept.size() >= 3 && kept.size() < edge_bearings.size()) plane = fitPlane(kept);
      planes[k] = *plane;
      // Scatter about the edge [px] (radians times pixels per radian along
      // the edge), and the variance of the fitted line at its ends: samples
      // span s in [0.15, 0.85], an end is 0.5 from their mean:
      // var = sigma^2 (1/N + 0.5^2 / (N 0.7^2 / 12)).
      const double angle =
          std::acos(std::clamp(corner_bearings[k].dot(corner_bearings[k1]), -1.0, 1.0));
      const double px_per_rad = angle > 0 ? length / angle : 0;
      double squares = 0;
      for (const Eigen::Vector3d& b : kept) squares += std::pow(plane->dot(b) * px_per_rad, 2);
      const double n = static_cast<double>(kept.size());
      const double sigma2 = n > 2 ? squares / (n - 2) : 0;
      variance_sum += sigma2 * (1.0 / n + 0.25 / (n * 0.49 / 12.0));
    }
    for (size_t k = 0; k < 4; ++k) {
      // Corner k joins edge k-1 (corner k-1 -> k) and edge k (corner k -> k+1).
      Eigen::Vector3d direction = planes[(k + 3) % 4].cross(planes[k]);
      if (direction.norm() < 1e-12) return fail("two parallel edges");
      direction.normalize();
      if (direction.dot(corner_bearings[k]) < 0) direction = -direction;
      const auto p = camera.project(direction);
      if (!p || (*p - initial[k]).norm() > 4.0)
        return fail("the edge fit moves a corner by more than 4 px from OpenCV's");
      corners[k] = *p;
    }
  }
  // Each corner's two coordinates get the mean variance of the ends of its two edges.
  if (corner_sigma_px) *corner_sigma_px = std::sqrt(variance_sum / 4.0);
  return corners;
}

std::vector<MarkerPoseHypothesis> MarkerDetector::solvePose(
    const std::array<Eigen::Vector2d, 4>& corners_px, double corner_sigma_px) const {
  const Camera& camera = impl_->camera;
  std::vector<cv::Point2d> normalised;
  for (const Eigen::Vector2d& px : corners_px) {
    const auto b = camera.unproject(px);
    if (!b || b->z() < 1e-3) return {};
    normalised.emplace_back(b->x() / b->z(), b->y() / b->z());
  }
  std::vector<cv::Point3d> object;
  for (const Eigen::Vector3d& o : impl_->object) object.emplace_back(o.x(), o.y(), o.z());
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    cv::solvePnPGeneric(object, normalised, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvecs, tvecs,
                        false, cv::SOLVEPNP_IPPE_SQUARE);
  } catch (const cv::Exception&) {
    return {};
  }
  std::vector<MarkerPoseHypothesis> hypotheses;
  for (size_t i = 0; i < rvecs.size(); ++i) {
    cv::Mat rotation_cv;
    cv::Rodrigues(rvecs[i], rotation_cv);
    Eigen::Matrix3d rotation;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) rotation(a, b) = rotation_cv.at<double>(a, b);
    Rigid3d pose(
        Eigen::Quaterniond(rotation).normalized(),
        Eigen::Vector3d(tvecs[i].at<double>(0), tvecs[i].at<double>(1), tvecs[i].at<double>(2)));
    if (pose.translation.z() <= 0) continue;
    // Gauss-Newton on the pixel reprojection error through the camera model.
    bool ok = true;
    for (int iteration = 0; iteration < 10; ++iteration) {
      const auto r0 = residuals(camera, pose, impl_->object, corners_px);
      const auto jac = jacobian(camera, pose, impl_->object, corners_px);
      if (!r0 || !jac) {
        ok = false;
        break;
      }
      const Eigen::Matrix<double, 6, 6> normal = jac->transpose() * *jac;
      const Eigen::Matrix<double, 6, 1> delta = -normal.ldlt().solve(jac->transpose() * *r0);
      if (!delta.allFinite()) {
        ok = false;
        break;
      }
      pose = perturbed(pose, delta);
      if (delta.norm() < 1e-12) break;
    }
    if (!ok) continue;
    const auto r = residuals(camera, pose, impl_->object, corners_px);
    const auto jac = jacobian(camera, pose, impl_->object, corners_px);
    if (!r || !jac || pose.translation.z() <= 0) continue;
    MarkerPoseHypothesis h;
    h.camera_from_marker = pose;
    h.reprojection_rms_px = std::sqrt(r->squaredNorm() / 4);
    const double sigma = corner_sigma_px > 0 ? corner_sigma_px : options_.corner_sigma_px;
    h.information = jac->transpose() * *jac / (sigma * sigma);
    // The marker must face the camera: its z axis towards the optical centre.
    const Eigen::Vector3d normal = pose.rotation * Eigen::Vector3d::UnitZ();
    if (normal.dot(-pose.translation) <= 0) continue;
    // Two IPPE solutions can refine into the same pose.
    bool duplicate = false;
    for (const MarkerPoseHypothesis& other : hypotheses) {
      duplicate = duplicate ||
                  rotationAngleBetween(other.camera_from_marker.rotation, pose.rotation) < 1e-6;
    }
    if (!duplicate) hypotheses.push_back(h);
  }
  std::sort(hypotheses.begin(), hypotheses.end(),
            [](const MarkerPoseHypothesis& a, const MarkerPoseHypothesis& b) {
              return a.reprojection_rms_px < b.reprojection_rms_px;
            });
  return hypotheses;
}

std::vector<MarkerDetection> MarkerDetector::detect(const cv::Mat& grey) {
  if (grey.type() != CV_8UC1 || grey.cols != impl_->camera.width() ||
      grey.rows != impl_->camera.height()) {
    throw Error("marker detection: expected a " + std::to_string(impl_->camera.width()) + "x" +
                std::to_string(impl_->camera.height()) + " greyscale frame, got " +
                std::to_string(grey.cols) + "x" + std::to_string(grey.rows) + " with " +
                std::to_string(grey.channels()) + " channel(s)");
  }
  // 1. Candidates of the right id, in full-resolution pixels.
  std::vector<std::array<Eigen::Vector2d, 4>> candidates;
  auto search = [&](const cv::Mat& image, double scale, const cv::Point& origin) {
    std::vector<std::vector<cv::Point2f>> corners, rejected;
    std::vector<int> ids;
    cv::aruco::detectMarkers(image, impl_->dictionary, corners, ids, impl_->parameters, rejected);
    for (size_t i = 0; i < ids.size(); ++i) {
      if (ids[i] != impl_->id) continue;
      std::array<Eigen::Vector2d, 4> c;
      for (size_t k = 0; k < 4; ++k) {
        // Pixel centres: full = scale * (reduced + 0.5) - 0.5.
        c[k] = Eigen::Vector2d(scale * (corners[i][k].x + 0.5) - 0.5 + origin.x,
                               scale * (corners[i][k].y + 0.5) - 0.5 + origin.y);
      }
      candidates.push_back(c);
    }
  };
  const cv::Rect frame(0, 0, grey.cols, grey.rows);
  if (options_.track_roi && impl_->last_box) {
    const cv::Rect& box = *impl_->last_box;
    const int margin =
        static_cast<int>(std::ceil(options_.roi_margin * std::max(box.width, box.height)));
    const cv::Rect roi =
        cv::Rect(box.x - margin, box.y - margin, box.width + 2 * margin, box.height + 2 * margin) &
        frame;
    if (roi.area() > 0) {
      const cv::Mat crop = grey(roi);
      // A large marker is searched at reduced resolution too.
      const int scale = std::max(1, std::min(impl_->scale, std::min(box.width, box.height) / 40));
      if (scale > 1) {
        cv::Mat reduced;
        cv::resize(crop, reduced, cv::Size(), 1.0 / scale, 1.0 / scale, cv::INTER_AREA);
        search(reduced, scale, roi.tl());
      } else {
        search(crop, 1.0, roi.tl());
      }
    }
  }
  if (candidates.empty()) {
    if (impl_->scale > 1) {
      cv::Mat reduced;
      cv::resize(grey, reduced, cv::Size(grey.cols / impl_->scale, grey.rows / impl_->scale), 0, 0,
                 cv::INTER_AREA);
      search(reduced, impl_->scale, cv::Point(0, 0));
    } else {
      search(grey, 1.0, cv::Point(0, 0));
    }
  }
  // 2-3. Corners, pose hypotheses, checks.
  std::vector<MarkerDetection> detections;
  impl_->last_box.reset();
  for (const auto& candidate : candidates) {
    ++stats_.candidates;
    double sigma = options_.corner_sigma_px;
    const std::array<Eigen::Vector2d, 4> corners = cornersOf(grey, candidate, &sigma);
    double shortest = 1e300;
    for (size_t k = 0; k < 4; ++k) {
      shortest = std::min(shortest, (corners[(k + 1) % 4] - corners[k]).norm());
    }
    if (shortest < options_.min_side_px) {
      ++stats_.rejected["a side shorter than min_side_px"];
      continue;
    }
    // Convex and consistently oriented.
    int sign = 0;
    bool convex = true;
    for (size_t k = 0; k < 4; ++k) {
      const Eigen::Vector2d a = corners[(k + 1) % 4] - corners[k];
      const Eigen::Vector2d b = corners[(k + 2) % 4] - corners[(k + 1) % 4];
      const double cross = a.x() * b.y() - a.y() * b.x();
      const int s = cross > 0 ? 1 : -1;
      convex = convex && std::abs(cross) > 1e-6 && (sign == 0 || s == sign);
      sign = s;
    }
    if (!convex) {
      ++stats_.rejected["not a convex quadrilateral"];
      continue;
    }
    MarkerDetection detection;
    detection.marker_id = impl_->id;
    detection.corners_px = corners;
    detection.corner_sigma_px = sigma;
    detection.hypotheses = solvePose(corners, sigma);
    if (detection.hypotheses.empty() ||
        detection.hypotheses.front().reprojection_rms_px > options_.max_reprojection_px) {
      ++stats_.rejected[detection.hypotheses.empty()
                            ? "no pose (degenerate corners)"
                            : "pose reprojection error above max_reprojection_px"];
      continue;
    }
    detection.ambiguous =
        detection.hypotheses.size() > 1 &&
        detection.hypotheses[1].reprojection_rms_px <
            options_.ambiguity_ratio * std::max(detection.hypotheses[0].reprojection_rms_px, 1e-3);
    std::vector<cv::Point2f> points;
    for (const Eigen::Vector2d& c : corners)
      points.emplace_back(static_cast<float>(c.x()), static_cast<float>(c.y()));
    const cv::Rect box = cv::boundingRect(points) & frame;
    impl_->last_box = impl_->last_box ? (*impl_->last_box | box) : box;
    detections.push_back(std::move(detection));
    ++stats_.accepted;
  }
  return detections;
}

std::array<Eigen::Vector2d, 4> MarkerDetector::cornersOf(
    const cv::Mat& grey, const std::array<Eigen::Vector2d, 4>& candidate, double* corner_sigma_px) {
  if (!options_.refine_edges) {
    *corner_sigma_px = options_.corner_sigma_px;
    return candidate;
  }
  std::string why;
  double sigma = 0;
  if (const auto refined = refineCorners(grey, candidate, &sigma, &why)) {
    ++stats_.refined;
    *corner_sigma_px = std::hypot(sigma, options_.min_corner_sigma_px);
    return *refined;
  }
  ++stats_.fallbacks;
  ++stats_.fallback_reasons[why];
  return subPixelCorners(grey, candidate, corner_sigma_px);
}

std::array<Eigen::Vector2d, 4> MarkerDetector::subPixelCorners(
    const cv::Mat& grey, const std::array<Eigen::Vector2d, 4>& corners_px,
    double* corner_sigma_px) const {
  std::vector<cv::Point2f> points;
  double shortest = 1e300;
  for (size_t k = 0; k < 4; ++k) {
    points.emplace_back(static_cast<float>(corners_px[k].x()),
                        static_cast<float>(corners_px[k].y()));
    shortest = std::min(shortest, (corners_px[(k + 1) % 4] - corners_px[k]).norm());
  }
  // A window within a cell of the marker (its border is one cell wide), so
  // that the search sees one corner only.
  const int half = std::clamp(static_cast<int>(shortest / (impl_->cells * 2.0)), 2, 8);
  cv::cornerSubPix(grey, points, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.01));
  std::array<Eigen::Vector2d, 4> corners;
  double squares = 0;
  for (size_t k = 0; k < 4; ++k) {
    corners[k] = Eigen::Vector2d(points[k].x, points[k].y);
    squares += (corners[k] - corners_px[k]).squaredNorm();
  }
  // Per coordinate: the disagreement with OpenCV's own corners, at least the
  // configured floor.
  *corner_sigma_px = std::max(options_.fallback_corner_sigma_px, std::sqrt(squares / 8.0));
  return corners;
}

int resolveAmbiguity(std::vector<MarkerDetection*>& track, double agreement_deg) {
  const double cos_agreement = std::cos(agreement_deg * kPi / 180.0);
  auto normalOf = [](const MarkerPoseHypothesis& h) -> Eigen::Vector3d {
    return h.camera_from_marker.rotation * Eigen::Vector3d::UnitZ();
  };
  // The track's normal: among all hypotheses' normals, the one that most
  // detections have a hypothesis within `agreement_deg` of (ties: the lower
  // sum of those hypotheses' reprojection errors); then the mean of those.
  int best_support = 0;
  double best_cost = 0;
  Eigen::Vector3d reference = Eigen::Vector3d::Zero();
  for (const MarkerDetection* d : track) {
    for (const MarkerPoseHypothesis& h : d->hypotheses) {
      const Eigen::Vector3d n = normalOf(h);
      int support = 0;
      double cost = 0;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (const MarkerDetection* e : track) {
        const MarkerPoseHypothesis* nearest = nullptr;
        double nearest_dot = cos_agreement;
        for (const MarkerPoseHypothesis& g : e->hypotheses) {
          const double dot = normalOf(g).dot(n);
          if (dot >= nearest_dot) {
            nearest_dot = dot;
            nearest = &g;
          }
        }
        if (nearest) {
          ++support;
          cost += nearest->reprojection_rms_px;
          sum += normalOf(*nearest);
        }
      }
      if (support > best_support || (support == best_support && cost < best_cost)) {
        best_support = support;
        best_cost = cost;
        reference = sum.normalized();
      }
    }
  }
  // One detection, or no two agreeing: nothing to decide with.
  if (best_support < 2) reference.setZero();
  int unresolved = 0;
  for (MarkerDetection* d : track) {
    d->chosen = 0;
    d->unresolved = false;
    if (d->hypotheses.size() < 2) continue;
    int best = -1;
    double best_dot = cos_agreement;
    for (size_t i = 0; i < d->hypotheses.size() && !reference.isZero(); ++i) {
      const double dot = normalOf(d->hypotheses[i]).dot(reference);
      if (dot >= best_dot) {
        best_dot = dot;
        best = static_cast<int>(i);
      }
    }
    if (best >= 0) {
      d->chosen = best;
    } else if (d->ambiguous) {
      d->unresolved = true;
      ++unresolved;
    }
  }
  return unresolved;
}

int rejectTrackOutliers(std::vector<std::pair<TimeNs, MarkerDetection>>& track,
                        double max_speed_mps, TimeNs window) {
  if (max_speed_mps <= 0) return 0;
  // Agreement with the nearest detection before and the nearest after
  // (others at the same time count as both).
  std::vector<bool> keep(track.size(), true);
  for (size_t i = 0; i < track.size(); ++i) {
    const Eigen::Vector3d& p = track[i].second.pose().camera_from_marker.translation;
    auto agreesWith = [&](size_t j) {
      const double seconds = std::abs(static_cast<double>(track[j].first - track[i].first)) * 1e-9;
      const Eigen::Vector3d& q = track[j].second.pose().camera_from_marker.translation;
      return (p - q).norm() <= max_speed_mps * seconds + 0.05;
    };
    bool has_neighbour = false, agrees = false;
    std::optional<size_t> before, after;
    for (size_t j = 0; j < track.size(); ++j) {
      if (j == i) continue;
      const TimeNs dt = track[j].first - track[i].first;
      if (dt == 0) {
        has_neighbour = true;
        agrees = agrees || agreesWith(j);
      } else if (dt < 0 && dt >= -window) {
        if (!before || track[j].first >= track[*before].first) before = j;
      } else if (dt > 0 && dt <= window) {
        if (!after || track[j].first < track[*after].first) after = j;
      }
    }
    for (const auto& j : {before, after}) {
      if (!j) continue;
      has_neighbour = true;
      agrees = agrees || agreesWith(*j);
    }
    keep[i] = !has_neighbour || agrees;
  }
  int removed = 0;
  std::vector<std::pair<TimeNs, MarkerDetection>> kept;
  for (size_t i = 0; i < track.size(); ++i) {
    if (keep[i]) {
      kept.push_back(std::move(track[i]));
    } else {
      ++removed;
    }
  }
  track = std::move(kept);
  return removed;
}

MarkerObservation toMarkerObservation(const MarkerDetection& detection, TimeNs t,
                                      const std::string& camera) {
  MarkerObservation obs;
  obs.t = t;
  obs.camera = camera;
  obs.marker_id = detection.marker_id;
  obs.camera_from_marker = detection.pose().camera_from_marker;
  obs.information = detection.pose().information;
  obs.corners_px.assign(detection.corners_px.begin(), detection.corners_px.end());
  obs.corner_sigma_px = detection.corner_sigma_px;
  return obs;
}

}  // namespace lookboth
