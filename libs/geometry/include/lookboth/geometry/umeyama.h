// Least-squares alignment of corresponding points (Umeyama 1991): the
// similarity or rigid transform dst_from_src minimising
//     sum_i w_i * || dst_i - (s R src_i + t) ||^2.
// Used to compare estimates with ground truth (lookboth evaluate) and to
// express one estimate in another's frame.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "lookboth/geometry/rigid3.h"
#include "lookboth/geometry/sim3.h"

namespace lookboth {

struct AlignmentResult {
  Sim3d dst_from_src;      ///< scale == 1 for rigid alignment.
  double rms_error = 0.0;  ///< RMS of || dst_i - dst_from_src * src_i || [dst units].
};

/// Similarity alignment. `weights` may be empty (all 1) or one per point,
/// non-negative. Returns nullopt, with the reason in *why_not when given, for
/// fewer than 3 points, mismatched sizes, or points that are coincident or
/// collinear (the rotation about their line is then undetermined).
std::optional<AlignmentResult> alignSim3(const std::vector<Eigen::Vector3d>& src,
                                         const std::vector<Eigen::Vector3d>& dst,
                                         const std::vector<double>& weights = {},
                                         std::string* why_not = nullptr);

/// Rigid alignment (scale fixed to 1); same rules as alignSim3.
std::optional<AlignmentResult> alignRigid3(const std::vector<Eigen::Vector3d>& src,
                                           const std::vector<Eigen::Vector3d>& dst,
                                           const std::vector<double>& weights = {},
                                           std::string* why_not = nullptr);

/// Alignment of corresponding poses a_from_x[i] ~ b_from_x[i] by their
/// positions: returns b_from_a (a similarity when with_scale). The same
/// degeneracy rules apply to the positions.
std::optional<AlignmentResult> alignPoses(const std::vector<Rigid3d>& a_from_x,
                                          const std::vector<Rigid3d>& b_from_x, bool with_scale,
                                          std::string* why_not = nullptr);

}  // namespace lookboth
