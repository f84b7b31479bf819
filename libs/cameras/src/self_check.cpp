#include "lookboth/cameras/self_check.h"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace lookboth {

std::string CameraSelfCheckOptions::check() const {
  if (num_rays <= 0) return "'num_rays': must be positive";
  if (num_pixels <= 0) return "'num_pixels': must be positive";
  if (!(max_ray_error > 0)) return "'max_ray_error': must be positive";
  if (!(max_pixel_error > 0)) return "'max_pixel_error': must be positive";
  return "";
}

CameraSelfCheck selfCheckCamera(const Camera& camera, const CameraSelfCheckOptions& options) {
  CameraSelfCheck result;
  result.field_of_view_deg = camera.fieldOfView() * 180.0 / M_PI;
  result.max_incidence_deg = camera.maxIncidenceAngle() * 180.0 / M_PI;
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);

  const double max_angle = camera.maxIncidenceAngle();
  for (int i = 0; i < options.num_rays; ++i) {
    // Uniform in angle (not in solid angle) so the rim is sampled as densely
    // as the centre: the rim is where models break.
    const double theta = max_angle * unit(rng);
    const double phi = 2.0 * M_PI * unit(rng);
    const Eigen::Vector3d ray(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                              std::cos(theta));
    ++result.rays_tested;
    const auto pixel = camera.project(ray);
    const auto back = pixel ? camera.unproject(*pixel) : std::nullopt;
    if (!back) {
      ++result.rays_failed;
      continue;
    }
    const double error = std::atan2(ray.cross(*back).norm(), ray.dot(*back));
    result.max_ray_error_rad = std::max(result.max_ray_error_rad, error);
  }

  for (int i = 0; i < options.num_pixels; ++i) {
    // v first: one order of the draws on every compiler (lookboth/geometry/random.h).
    const double v = -0.5 + camera.height() * unit(rng);
    const Eigen::Vector2d pixel(-0.5 + camera.width() * unit(rng), v);
    const auto ray = camera.unproject(pixel);
    if (!ray) {
      ++result.pixels_without_ray;
      continue;
    }
    const auto back = camera.project(*ray);
    ++result.pixels_tested;
    const double error = back ? (*back - pixel).norm() : INFINITY;
    result.max_pixel_error_px = std::max(result.max_pixel_error_px, error);
  }

  // A little past the valid domain must be reported invalid, not mapped.
  const double beyond = max_angle + 1.0 * M_PI / 180.0;
  if (beyond < M_PI) {
    for (int i = 0; i < 36; ++i) {
      const double phi = 2.0 * M_PI * i / 36.0;
      const Eigen::Vector3d ray(std::sin(beyond) * std::cos(phi), std::sin(beyond) * std::sin(phi),
                                std::cos(beyond));
      if (camera.project(ray)) result.rejects_beyond_fov = false;
    }
  }

  result.passed = result.rays_failed == 0 && result.max_ray_error_rad <= options.max_ray_error &&
                  result.max_pixel_error_px <= options.max_pixel_error &&
                  result.rejects_beyond_fov && result.pixels_tested > 0;
  return result;
}

}  // namespace lookboth
