// Ray-cast rendering through lookboth's camera models (render.h).
#include "lookboth/sim/render.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <list>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/aruco.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <string>
#include <vector>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"

namespace lookboth::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
/// Grey levels of the backlit marker: white cells (times the brightness),
/// black cells (the print lets a little light through).
constexpr double kMarkerWhite = 0.92;
constexpr double kMarkerBlack = 0.035;
/// The body's underside height above the floor [m].
constexpr double kBodyClearance = 0.02;
/// The marker panel wins over the body's top plate when both are hit within
/// this distance [m] (the panel lies on the plate).
constexpr double kPanelTolerance = 2e-3;

// ---------------------------------------------------------------- bearing tables

/// Bearings of the pixel-centre lattice u = -1..w, v = -1..h (NaN where the
/// model has no ray), in floats: index ((v + 1) * (w + 2) + (u + 1)) * 3.
struct RayTable {
  int width = 0, height = 0;
  std::vector<float> bearings;
};

std::string fingerprint(const Camera& camera) {
  std::string key = camera.modelName() + ":" + std::to_string(camera.width()) + "x" +
                    std::to_string(camera.height());
  if (const auto* s = std::get_if<ScaramuzzaModel>(&camera.model())) {
    key += ":" + std::to_string(s->num_poly) + "," + std::to_string(s->num_inv_poly);
  }
  key += ":";
  const std::vector<double>& params = camera.params();
  const std::size_t at = key.size();
  key.resize(at + params.size() * sizeof(double));
  std::memcpy(&key[at], params.data(), params.size() * sizeof(double));
  return key;
}

std::shared_ptr<const RayTable> buildRayTable(const Camera& camera) {
  auto table = std::make_shared<RayTable>();
  table->width = camera.width();
  table->height = camera.height();
  const int lw = table->width + 2, lh = table->height + 2;
  table->bearings.assign(static_cast<std::size_t>(lw) * lh * 3,
                         std::numeric_limits<float>::quiet_NaN());
  cv::parallel_for_(cv::Range(0, lh), [&](const cv::Range& rows) {
    for (int j = rows.start; j < rows.end; ++j) {
      for (int i = 0; i < lw; ++i) {
        const std::optional<Eigen::Vector3d> b =
            camera.unproject(Eigen::Vector2d(i - 1.0, j - 1.0));
        if (!b) continue;
        float* out = &table->bearings[(static_cast<std::size_t>(j) * lw + i) * 3];
        out[0] = static_cast<float>(b->x());
        out[1] = static_cast<float>(b->y());
        out[2] = static_cast<float>(b->z());
      }
    }
  });
  return table;
}

std::mutex g_cache_mutex;
std::list<std::pair<std::string, std::shared_ptr<const RayTable>>> g_cache;  // most recent first
constexpr std::size_t kCacheCapacity = 4;

std::shared_ptr<const RayTable> rayTable(const Camera& camera) {
  const std::string key = fingerprint(camera);
  {
    std::lock_guard<std::mutex> lock(g_cache_mutex);
    for (auto it = g_cache.begin(); it != g_cache.end(); ++it) {
      if (it->first == key) {
        g_cache.splice(g_cache.begin(), g_cache, it);
        return g_cache.front().second;
      }
    }
  }
  std::shared_ptr<const RayTable> table = buildRayTable(camera);  // outside the lock: slow
  std::lock_guard<std::mutex> lock(g_cache_mutex);
  g_cache.emplace_front(key, table);
  while (g_cache.size() > kCacheCapacity) g_cache.pop_back();
  return table;
}

/// Bearing of a (sub-)pixel: bilinear in the table, the exact model where a
/// table neighbour has no ray. False when the model has no ray there.
bool bearingAt(const RayTable& table, const Camera& camera, double u, double v,
               Eigen::Vector3d* bearing) {
  const int lw = table.width + 2;
  const double x = u + 1.0, y = v + 1.0;
  // x, y >= 0.5 for pixels of the image (u, v >= -0.5): truncation is floor.
  const int i = std::min(static_cast<int>(std::max(x, 0.0)), table.width);
  const int j = std::min(static_cast<int>(std::max(y, 0.0)), table.height);
  const double tx = x - i, ty = y - j;
  const float* a = &table.bearings[(static_cast<std::size_t>(j) * lw + i) * 3];
  const float* b = a + 3;
  const float* c = a + static_cast<std::size_t>(lw) * 3;
  const float* d = c + 3;
  const int missing = std::isnan(a[0]) + std::isnan(b[0]) + std::isnan(c[0]) + std::isnan(d[0]);
  if (missing == 4) return false;  // well outside the valid field of view
  if (missing > 0) {
    const std::optional<Eigen::Vector3d> exact = camera.unproject(Eigen::Vector2d(u, v));
    if (!exact) return false;
    *bearing = *exact;
    return true;
  }
  const double wa = (1 - tx) * (1 - ty), wb = tx * (1 - ty), wc = (1 - tx) * ty, wd = tx * ty;
  for (int k = 0; k < 3; ++k) (*bearing)[k] = wa * a[k] + wb * b[k] + wc * c[k] + wd * d[k];
  bearing->normalize();
  return true;
}

// ---------------------------------------------------------------- casting and finishing

/// Mean radiance of an s x s grid of rays over pixel (u, v).
template <typename Radiance>
float gridRadiance(const Camera& camera, const RayTable& table, int u, int v, int s,
                   const Radiance& radiance) {
  Eigen::Vector3d bearing;
  double sum = 0.0;
  for (int b = 0; b < s; ++b) {
    const double dv = (b + 0.5) / s - 0.5;
    for (int a = 0; a < s; ++a) {
      const double du = (a + 0.5) / s - 0.5;
      if (bearingAt(table, camera, u + du, v + dv, &bearing)) sum += radiance(bearing);
    }
  }
  return static_cast<float>(sum / (s * s));
}

/// Supersampled radiance of every pixel; `valid` is 255 where the pixel
/// centre has a ray. `radiance(bearing)` is called concurrently.
///
/// Adaptive: rays are first cast through the pixel corners (one per pixel,
/// shared by four pixels); a pixel whose four corner radiances agree within
/// `tolerance` takes their mean, the others (edges, fine texture) and all
/// pixels of the `high` rectangle get a regular grid of s x s rays (s =
/// `ss`, or `ss_high` in `high`). With ss = 1 there is one ray per pixel
/// centre and no corner pass.
template <typename Radiance>
cv::Mat1f castRays(const Camera& camera, const RayTable& table, int ss, int ss_high,
                   const cv::Rect& high, double tolerance, cv::Mat1b* valid,
                   const Radiance& radiance) {
  const int w = camera.width(), h = camera.height();
  cv::Mat1f image(h, w);
  *valid = cv::Mat1b(h, w);
  const bool adaptive = ss > 1;
  cv::Mat1f corners;
  if (adaptive) {
    corners = cv::Mat1f(h + 1, w + 1);
    cv::parallel_for_(
        cv::Range(0, h + 1),
        [&](const cv::Range& rows) {
          Eigen::Vector3d bearing;
          for (int j = rows.start; j < rows.end; ++j) {
            float* out = corners.ptr<float>(j);
            for (int i = 0; i <= w; ++i) {
              out[i] = bearingAt(table, camera, i - 0.5, j - 0.5, &bearing)
                           ? static_cast<float>(radiance(bearing))
                           : std::numeric_limits<float>::quiet_NaN();
            }
          }
        },
        std::max(1.0, h / 8.0));
  }
  cv::parallel_for_(
      cv::Range(0, h),
      [&](const cv::Range& rows) {
        for (int v = rows.start; v < rows.end; ++v) {
          float* out = image.ptr<float>(v);
          std::uint8_t* ok = valid->ptr<std::uint8_t>(v);
          for (int u = 0; u < w; ++u) {
            const float* centre =
                &table.bearings[(static_cast<std::size_t>(v + 1) * (w + 2) + (u + 1)) * 3];
            ok[u] = std::isnan(centre[0]) ? 0 : 255;
            const bool in_high = high.contains(cv::Point(u, v));
            const int s = in_high ? ss_high : ss;
            if (adaptive && !in_high) {
              const float c[4] = {corners(v, u), corners(v, u + 1), corners(v + 1, u),
                                  corners(v + 1, u + 1)};
              const float lo = std::min(std::min(c[0], c[1]), std::min(c[2], c[3]));
              const float hi = std::max(std::max(c[0], c[1]), std::max(c[2], c[3]));
              if (hi - lo <= tolerance) {  // false when any is NaN
                out[u] = 0.25f * (c[0] + c[1] + c[2] + c[3]);
                continue;
              }
            }
            out[u] = gridRadiance(camera, table, u, v, s, radiance);
          }
        }
      },
      std::max(1.0, h / 8.0));
  return image;
}

/// Recasts the pixels of `region` of `image` on a regular s x s grid each,
/// as castRays does in its `high` rectangle.
template <typename Radiance>
void castRegion(const Camera& camera, const RayTable& table, int s, const cv::Rect& region,
                cv::Mat1f& image, const Radiance& radiance) {
  cv::parallel_for_(cv::Range(region.y, region.y + region.height), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      float* out = image.ptr<float>(v);
      for (int u = region.x; u < region.x + region.width; ++u)
        out[u] = gridRadiance(camera, table, u, v, s, radiance);
    }
  });
}

/// Radiance difference below which corner samples are trusted: 5 grey
/// levels after the exposure gain (below the sensor noise's +-2 sigma).
double adaptiveTolerance(const RenderOptions& options) { return 5.0 / (255.0 * options.exposure); }

/// Approximately standard normal from a hash of (seed, u, v): Irwin-Hall sum
/// of four 16-bit uniforms, rescaled to unit variance.
double pixelNoise(std::uint64_t seed, int u, int v) {
  std::uint64_t z = seed ^ (static_cast<std::uint64_t>(static_cast<std::uint32_t>(v)) << 32 |
                            static_cast<std::uint32_t>(u));
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  double sum = 0.0;
  for (int k = 0; k < 4; ++k) sum += static_cast<double>((z >> (16 * k)) & 0xFFFFu) / 65536.0;
  return (sum - 2.0) * std::sqrt(3.0);
}

cv::Mat finish(cv::Mat1f radiance, const cv::Mat1b& valid, const RenderOptions& options,
               std::uint64_t seed) {
  if (options.blur_sigma_px > 0.0) {
    cv::GaussianBlur(radiance, radiance, cv::Size(), options.blur_sigma_px, options.blur_sigma_px,
                     cv::BORDER_REFLECT);
  }
  if (options.motion_blur_px > 0.0) {
    // A box of the given length (fractional ends), centred.
    const double length = std::max(1.0, options.motion_blur_px);
    const int half = static_cast<int>(std::ceil(0.5 * length));
    cv::Mat1f kernel(1, 2 * half + 1, 0.0f);
    for (int k = -half; k <= half; ++k) {
      const double lo = std::max(k - 0.5, -0.5 * length), hi = std::min(k + 0.5, 0.5 * length);
      kernel(0, k + half) = static_cast<float>(std::max(0.0, hi - lo) / length);
    }
    cv::filter2D(radiance, radiance, -1, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
  }
  cv::Mat1b out(radiance.rows, radiance.cols);
  const double gain = 255.0 * options.exposure;
  cv::parallel_for_(cv::Range(0, radiance.rows), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      const float* in = radiance.ptr<float>(v);
      const std::uint8_t* ok = valid.ptr<std::uint8_t>(v);
      std::uint8_t* o = out.ptr<std::uint8_t>(v);
      for (int u = 0; u < radiance.cols; ++u) {
        if (!ok[u]) {
          o[u] = 0;
          continue;
        }
        double value = gain * in[u];
        if (options.noise_sigma > 0.0) value += options.noise_sigma * pixelNoise(seed, u, v);
        o[u] = cv::saturate_cast<std::uint8_t>(value);
      }
    }
  });
  return out;
}

std::uint64_t drawSeed(std::mt19937& rng) {
  const std::uint64_t hi = rng();
  return (hi << 32) | rng();
}

double vignette(const RenderOptions& options, const Eigen::Vector3d& bearing) {
  return std::max(0.0, 1.0 - options.vignetting * (1.0 - bearing.z()));
}

void checkInputs(const RenderOptions& options) {
  const std::string message = options.check();
  if (!message.empty()) throw Error(ErrorContext{"", 0, "render options", ""}, message);
}

}  // namespace

// ---------------------------------------------------------------- options, markers

std::string RenderOptions::check() const {
  const auto bad = [](const std::string& field, const std::string& what, double value) {
    return "'" + field + "': " + what + ", got " + formatDouble(value);
  };
  if (supersampling < 1 || supersampling > 16)
    return bad("supersampling", "must be in [1, 16]", supersampling);
  if (marker_supersampling < 1 || marker_supersampling > 16) {
    return bad("marker_supersampling", "must be in [1, 16]", marker_supersampling);
  }
  if (!(noise_sigma >= 0.0 && noise_sigma <= 100.0))
    return bad("noise_sigma", "must be in [0, 100]", noise_sigma);
  if (!(exposure > 0.0 && exposure <= 100.0))
    return bad("exposure", "must be in (0, 100]", exposure);
  if (!(motion_blur_px >= 0.0 && motion_blur_px <= 500.0)) {
    return bad("motion_blur_px", "must be in [0, 500]", motion_blur_px);
  }
  if (!(blur_sigma_px >= 0.0 && blur_sigma_px <= 20.0))
    return bad("blur_sigma_px", "must be in [0, 20]", blur_sigma_px);
  if (!(vignetting >= 0.0 && vignetting <= 1.0))
    return bad("vignetting", "must be in [0, 1]", vignetting);
  if (!(fisheye_fov_rad >= 0.0 && fisheye_fov_rad <= 2.0 * kPi)) {
    return bad("fisheye_fov_rad", "must be in [0, 2 pi]", fisheye_fov_rad);
  }
  return "";
}

cv::Mat markerCells(const MarkerSpec& marker) {
  const std::string message = marker.check();
  if (!message.empty()) throw Error(ErrorContext{"", 0, "marker", ""}, message);
  const cv::Ptr<cv::aruco::Dictionary> dictionary = cv::aruco::getPredefinedDictionary(
      static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(arucoDictionaryId(marker.dictionary)));
  const int cells = dictionary->markerSize + 2;
  // Drawn at 8 px per cell, read at the cell centres.
  constexpr int kPerCell = 8;
  cv::Mat drawn;
  cv::aruco::drawMarker(dictionary, marker.id, cells * kPerCell, drawn, 1);
  cv::Mat1b out(cells, cells);
  for (int r = 0; r < cells; ++r) {
    for (int c = 0; c < cells; ++c) {
      out(r, c) =
          drawn.at<std::uint8_t>(r * kPerCell + kPerCell / 2, c * kPerCell + kPerCell / 2) > 127
              ? 255
              : 0;
    }
  }
  return std::move(out);
}

void clearRenderCache() {
  std::lock_guard<std::mutex> lock(g_cache_mutex);
  g_cache.clear();
}

// ---------------------------------------------------------------- fisheye

cv::Mat renderFisheye(const World& world, const Camera& fisheye, const Rigid3d& world_from_fisheye,
                      const RenderOptions& options, std::mt19937& rng) {
  checkInputs(options);
  const std::uint64_t seed = drawSeed(rng);
  const std::shared_ptr<const RayTable> table = rayTable(fisheye);
  const double fov =
      options.fisheye_fov_rad > 0.0 ? options.fisheye_fov_rad : fisheye.fieldOfView();
  const double cos_limit = std::cos(std::min(0.5 * fov, kPi));
  const Eigen::Matrix3d rotation = world_from_fisheye.rotation.toRotationMatrix();
  const Eigen::Vector3d origin = world_from_fisheye.translation;
  const auto radiance = [&](const Eigen::Vector3d& bearing) {
    if (bearing.z() < cos_limit) return 0.0;  // outside the lens' image circle
    const Hit hit = world.intersect(origin, rotation * bearing);
    return world.shade(hit) * vignette(options, bearing);
  };
  cv::Mat1b valid;
  cv::Mat1f image = castRays(fisheye, *table, options.supersampling, options.supersampling,
                             cv::Rect(), adaptiveTolerance(options), &valid, radiance);
  // Pixels whose centre is outside the image circle are black too.
  cv::parallel_for_(cv::Range(0, valid.rows), [&](const cv::Range& rows) {
    for (int v = rows.start; v < rows.end; ++v) {
      for (int u = 0; u < valid.cols; ++u) {
        if (!valid(v, u)) continue;
        const float* b =
            &table->bearings[(static_cast<std::size_t>(v + 1) * (valid.cols + 2) + (u + 1)) * 3];
        if (b[2] < cos_limit) valid(v, u) = 0;
      }
    }
  });
  return finish(image, valid, options, seed);
}

// ---------------------------------------------------------------- environment camera

namespace {

/// Where the robot can appear in an environment camera's image: the
/// bounding rectangle of the projections of points on its body and its
/// marker panel, with a margin for the blur (empty when out of view). Rays
/// there are supersampled more finely; a frame made from a background
/// recasts only these pixels.
cv::Rect robotImageBox(const Camera& camera, const Rigid3d& world_from_camera,
                       const RobotAppearance& robot, const Eigen::AlignedBox3d& body,
                       double half_panel, const RenderOptions& options) {
  cv::Rect high;
  const Rigid3d camera_from_world = world_from_camera.inverse();
  double u0 = kInf, v0 = kInf, u1 = -kInf, v1 = -kInf;
  bool unprojected = false;  // a point beyond the model's field of view
  const auto addPoint = [&](const Eigen::Vector3d& p_in_world) {
    const std::optional<Eigen::Vector2d> px = camera.project(camera_from_world * p_in_world);
    if (!px || !px->allFinite()) {
      unprojected = true;
      return;
    }
    u0 = std::min(u0, px->x());
    v0 = std::min(v0, px->y());
    u1 = std::max(u1, px->x());
    v1 = std::max(v1, px->y());
  };
  constexpr int kSteps = 4;
  for (int a = 0; a <= kSteps; ++a) {
    for (int b = 0; b <= kSteps; ++b) {
      for (int c = 0; c <= 1; ++c) {
        const Eigen::Vector3d f(static_cast<double>(a) / kSteps, static_cast<double>(b) / kSteps,
                                c);
        const Eigen::Vector3d p = body.min() + f.cwiseProduct(body.max() - body.min());
        addPoint(robot.world_from_base * p);
      }
      const double x = (2.0 * a / kSteps - 1.0) * half_panel,
                   y = (2.0 * b / kSteps - 1.0) * half_panel;
      addPoint(robot.world_from_marker * Eigen::Vector3d(x, y, 0.0));
    }
  }
  if (u0 <= u1) {
    int margin =
        3 + static_cast<int>(std::ceil(3.0 * options.blur_sigma_px + options.motion_blur_px));
    // Part of the robot beyond the model's field of view (at the image's
    // edge): between the last point that projects and the first that does
    // not, the robot can still be in the image, within about one step of
    // the sampling grid (a frame made from a background would clip it).
    if (unprojected) margin += static_cast<int>(std::ceil(std::max(u1 - u0, v1 - v0) / kSteps));
    high = cv::Rect(cv::Point(static_cast<int>(std::floor(std::max(u0, -1e6))) - margin,
                              static_cast<int>(std::floor(std::max(v0, -1e6))) - margin),
                    cv::Point(static_cast<int>(std::ceil(std::min(u1, 1e6))) + margin + 1,
                              static_cast<int>(std::ceil(std::min(v1, 1e6))) + margin + 1)) &
           cv::Rect(0, 0, camera.width(), camera.height());
  }
  return high;
}

}  // namespace

cv::Mat renderEnvCamera(const World& world, const Camera& camera, const Rigid3d& world_from_camera,
                        const RobotAppearance& robot, const RenderOptions& options,
                        std::mt19937& rng, const EnvBackground* background) {
  checkInputs(options);
  if (!(robot.marker_margin >= 0.0 && robot.marker_margin <= 10.0)) {
    throw Error(ErrorContext{"", 0, "marker_margin", ""},
                "must be in [0, 10], got " + formatDouble(robot.marker_margin));
  }
  const cv::Mat1b cells = markerCells(robot.marker);
  const std::uint64_t seed = drawSeed(rng);
  const std::shared_ptr<const RayTable> table = rayTable(camera);
  const Eigen::Matrix3d rotation = world_from_camera.rotation.toRotationMatrix();
  const Eigen::Vector3d origin = world_from_camera.translation;

  // The robot's body in its base frame, the marker panel in the marker frame.
  const Eigen::AlignedBox3d body(
      Eigen::Vector3d(-0.5 * robot.body_length_m, -0.5 * robot.body_width_m, kBodyClearance),
      Eigen::Vector3d(0.5 * robot.body_length_m, 0.5 * robot.body_width_m, robot.body_height_m));
  const Rigid3d base_from_world = robot.world_from_base.inverse();
  const Rigid3d marker_from_world = robot.world_from_marker.inverse();
  const Eigen::Matrix3d base_rotation = base_from_world.rotation.toRotationMatrix();
  const Eigen::Matrix3d marker_rotation = marker_from_world.rotation.toRotationMatrix();
  const Eigen::Vector3d origin_in_base = base_from_world * origin;
  const Eigen::Vector3d origin_in_marker = marker_from_world * origin;
  const double side = robot.marker.size_m;
  const double half_panel = side * (0.5 + robot.marker_margin);
  const int n = cells.rows;
  const double white = kMarkerWhite * std::clamp(robot.marker_brightness, 0.0, 1.0);
  const Eigen::Vector3d robot_xy = robot.world_from_base.translation;
  const double robot_light = world.illumination(robot_xy.x(), robot_xy.y());
  const std::uint32_t body_seed = 0xB0D1u;

  const auto radiance = [&](const Eigen::Vector3d& bearing) {
    const Eigen::Vector3d d = rotation * bearing;
    const Hit hit = world.intersect(origin, d);
    double best = hit.distance;
    // The body.
    const Eigen::Vector3d d_base = base_rotation * d;
    double t_body = kInf;
    Eigen::Vector3d body_normal;
    const bool on_body =
        rayBoxEntry(body, origin_in_base, d_base, &t_body, &body_normal) && t_body < best;
    // The marker panel (seen from its front).
    const Eigen::Vector3d d_marker = marker_rotation * d;
    if (d_marker.z() < 0.0) {
      const double t = -origin_in_marker.z() / d_marker.z();
      const double limit = on_body ? t_body + kPanelTolerance : best;
      if (t > 0.0 && t < limit) {
        const double x = origin_in_marker.x() + t * d_marker.x();
        const double y = origin_in_marker.y() + t * d_marker.y();
        if (std::abs(x) <= half_panel && std::abs(y) <= half_panel) {
          const int c = static_cast<int>(std::floor((x + 0.5 * side) / side * n));
          const int r = static_cast<int>(std::floor((0.5 * side - y) / side * n));
          const bool black = c >= 0 && c < n && r >= 0 && r < n && cells(r, c) == 0;
          return (black ? kMarkerBlack : white) * vignette(options, bearing);
        }
      }
    }
    if (on_body) {
      const Eigen::Vector3d p = origin_in_base + t_body * d_base;
      double albedo;
      if (body_normal.z() > 0.5) {
        // Top plate: dark anodised aluminium, a lighter rim, a few bolt heads.
        albedo = 0.2 + 0.04 * valueNoise(p.x() / 0.03, p.y() / 0.03, body_seed);
        const double rim = std::min(0.5 * robot.body_length_m - std::abs(p.x()),
                                    0.5 * robot.body_width_m - std::abs(p.y()));
        if (rim < 0.012) albedo = 0.42;
        for (double bx : {-0.4, 0.4}) {
          for (double by : {-0.4, 0.4}) {
            const double dx = p.x() - bx * robot.body_length_m,
                         dy = p.y() - by * robot.body_width_m;
            if (dx * dx + dy * dy < 0.008 * 0.008) albedo = 0.6;
          }
        }
      } else {
        albedo = 0.3 + 0.03 * valueNoise(p.x() / 0.05, p.z() / 0.05, body_seed + 1u);
      }
      return albedo * robot_light * vignette(options, bearing);
    }
    return world.shade(hit) * vignette(options, bearing);
  };

  const cv::Rect high = robotImageBox(camera, world_from_camera, robot, body, half_panel, options);
  const int ss_high = std::max(options.supersampling, options.marker_supersampling);
  cv::Mat1b valid;
  cv::Mat1f image;
  if (background) {
    image = background->radiance.clone();
    valid = background->valid;
    if (!high.empty()) castRegion(camera, *table, ss_high, high, image, radiance);
  } else {
    image = castRays(camera, *table, options.supersampling, ss_high, high,
                     adaptiveTolerance(options), &valid, radiance);
  }
  return finish(image, valid, options, seed);
}

EnvBackground renderEnvBackground(const World& world, const Camera& camera,
                                  const Rigid3d& world_from_camera, const RenderOptions& options) {
  checkInputs(options);
  const std::shared_ptr<const RayTable> table = rayTable(camera);
  const Eigen::Matrix3d rotation = world_from_camera.rotation.toRotationMatrix();
  const Eigen::Vector3d origin = world_from_camera.translation;
  const auto radiance = [&](const Eigen::Vector3d& bearing) {
    return world.shade(world.intersect(origin, rotation * bearing)) * vignette(options, bearing);
  };
  EnvBackground background;
  background.radiance =
      castRays(camera, *table, options.supersampling, options.supersampling, cv::Rect(),
               adaptiveTolerance(options), &background.valid, radiance);
  return background;
}

}  // namespace lookboth::sim
