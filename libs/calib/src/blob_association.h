// The association rule of looking up (paper eq. 4-5, with gates), shared by
// the look_up and joint stages.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "lookboth/obs/CObservationBlobs.h"

namespace lookboth::calib_detail {

/// The blobs of one fisheye frame by column (u), for associatedBlob(): each
/// camera projected into the frame looks only at the blobs within
/// ambiguity_ratio x gate_px of its column, instead of at all of them.
class BlobsByColumn {
 public:
  struct Entry {
    double u, v;
    std::size_t index;  ///< in the frame's blob list
  };
  void assign(const std::vector<Blob>& blobs) {
    entries_.clear();
    for (std::size_t b = 0; b < blobs.size(); ++b) entries_.push_back({blobs[b].u, blobs[b].v, b});
    std::sort(entries_.begin(), entries_.end(), [](const Entry& a, const Entry& b) {
      return a.u < b.u || (a.u == b.u && a.index < b.index);
    });
  }
  const std::vector<Entry>& entries() const { return entries_; }

 private:
  std::vector<Entry> entries_;
};

/// The blob that camera `camera`, projected at `pixel`, is associated with in
/// one fisheye frame: the nearest blob within `gate_px`, the second nearest at
/// least `ambiguity_ratio` (>= 1) times farther, and no other camera of
/// `projected` (camera index, pixel: every camera projected into the frame)
/// that close to that blob. nullopt when there is none.
///
/// Only blobs within ambiguity_ratio x gate_px of the pixel can decide: the
/// nearest must lie within the gate, and a second nearest matters only when
/// it is closer than ambiguity_ratio times the nearest. Distances are
/// compared squared; of blobs at the same distance the one first in the
/// frame's list is the nearest (as a scan of the list in order finds).
inline std::optional<std::size_t> associatedBlob(
    const BlobsByColumn& blobs, std::size_t camera, const Eigen::Vector2d& pixel, double gate_px,
    double ambiguity_ratio, const std::vector<std::pair<std::size_t, Eigen::Vector2d>>& projected) {
  const double reach = ambiguity_ratio * gate_px;
  const auto& entries = blobs.entries();
  auto it = std::lower_bound(entries.begin(), entries.end(), pixel.x() - reach,
                             [](const BlobsByColumn::Entry& e, double u) { return e.u < u; });
  constexpr double kFar = std::numeric_limits<double>::infinity();
  double d1 = kFar, d2 = kFar;  // squared
  std::size_t best = 0;
  const BlobsByColumn::Entry* nearest = nullptr;
  for (; it != entries.end() && it->u <= pixel.x() + reach; ++it) {
    const double du = it->u - pixel.x(), dv = it->v - pixel.y();
    const double d = du * du + dv * dv;
    if (d < d1 || (d == d1 && it->index < best)) {
      d2 = d1;
      d1 = d;
      best = it->index;
      nearest = &*it;
    } else if (d < d2) {
      d2 = d;
    }
  }
  const double ratio2 = ambiguity_ratio * ambiguity_ratio;
  if (nearest == nullptr || d1 > gate_px * gate_px || d2 < ratio2 * d1) return std::nullopt;
  const Eigen::Vector2d blob(nearest->u, nearest->v);
  for (const auto& [other, other_pixel] : projected) {
    if (other != camera && (other_pixel - blob).squaredNorm() < ratio2 * d1) return std::nullopt;
  }
  return best;
}

/// The same rule by a scan of every blob (the reference of the tests).
inline std::optional<std::size_t> associatedBlobByScan(
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
