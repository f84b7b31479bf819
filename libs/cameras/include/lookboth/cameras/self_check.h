// A numerical self-check of a camera model over its whole valid field of
// view: what `lookboth camera check` prints and what the demo runs first.
#pragma once

#include <cstdint>

#include "lookboth/cameras/camera.h"

namespace lookboth {

struct CameraSelfCheckOptions {
  int num_rays = 5000;            ///< Random rays over the valid field of view.
  int num_pixels = 5000;          ///< Random pixels over the image.
  std::uint32_t seed = 1;         ///< Random seed (the check is deterministic).
  double max_ray_error = 1e-9;    ///< Pass bound on unproject(project(ray)) [rad].
  double max_pixel_error = 1e-6;  ///< Pass bound on project(unproject(pixel)) [px].
  /// Empty when valid, else a message naming the field.
  std::string check() const;
};

struct CameraSelfCheck {
  double field_of_view_deg = 0;  ///< Full FoV across the image [deg].
  double max_incidence_deg = 0;  ///< Half-angle of the valid model domain [deg].
  int rays_tested = 0;
  int rays_failed = 0;             ///< Rays in the valid FoV that did not project.
  double max_ray_error_rad = 0;    ///< Worst unproject(project(ray)) angle error.
  int pixels_tested = 0;           ///< Pixels with a valid unprojection.
  int pixels_without_ray = 0;      ///< Image pixels outside the model's domain.
  double max_pixel_error_px = 0;   ///< Worst project(unproject(pixel)) error.
  bool rejects_beyond_fov = true;  ///< Rays past the valid FoV are reported invalid.
  bool passed = false;
};

CameraSelfCheck selfCheckCamera(const Camera& camera, const CameraSelfCheckOptions& options = {});

}  // namespace lookboth
