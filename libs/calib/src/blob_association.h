// The association rule of looking up (paper eq. 4-5, with gates), shared by
// the look_up and joint stages.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <utility>
#include <vector>

#include "lookboth/obs/CObservationBlobs.h"

namespace lookboth::calib_detail {

/// The blob that camera `camera`, projected at `pixel`, is associated with in
/// one fisheye frame: the nearest blob within `gate_px`, the second nearest at
/// least `ambiguity_ratio` times farther, and no other camera of `projected`
/// (camera index, pixel: every camera projected into the frame) that close to
/// that blob. nullopt when there is none.
inline std::optional<std::size_t> associatedBlob(
    const std::vector<Blob>& blobs, std::size_t camera, const Eigen::Vector2d& pixel,
    double gate_px, double ambiguity_ratio,
    const std::vector<std::pair<std::size_t, Eigen::Vector2d>>& projected) {
  double d1 = 1e300, d2 = 1e300;
  std::size_t best = 0;
  for (std::size_t b = 0; b < blobs.size(); ++b) {
    const double d = (Eigen::Vector2d(blobs[b].u, blobs[b].v) - pixel).norm();
    if (d < d1) {
      d2 = d1;
      d1 = d;
      best = b;
    } else if (d < d2) {
      d2 = d;
    }
  }
  if (d1 > gate_px || d2 < ambiguity_ratio * d1) return std::nullopt;
  const Eigen::Vector2d blob(blobs[best].u, blobs[best].v);
  for (const auto& [other, other_pixel] : projected) {
    if (other != camera && (other_pixel - blob).norm() < ambiguity_ratio * d1) return std::nullopt;
  }
  return best;
}

}  // namespace lookboth::calib_detail
