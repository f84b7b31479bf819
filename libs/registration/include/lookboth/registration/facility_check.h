// Re-checking a registered facility (`lookboth check`; doc/formats.md,
// "Re-checking a facility"): a new registration, from a later drive, against
// the one on record. The two are aligned over the cameras that agree, and
// each camera gets a verdict: unchanged, moved (by how much, how many sigmas
// of both registrations' uncertainty), not seen by the new drive, or new.
#pragma once

#include <string>
#include <vector>

#include "lookboth/registration/registration.h"

namespace lookboth {

struct FacilityCheckOptions {
  /// A camera has moved when its difference is both significant (chi-square
  /// over 3 dof above this: 16.27 is 99.9 %) and larger than the tolerance
  /// below, in position or in rotation.
  double max_chi2 = 16.27;
  double min_position_m = 0.01;  ///< Smaller moves are "unchanged" whatever their significance [m].
  double min_rotation_deg = 0.5;  ///< [deg]
  /// Empty when usable; else what is wrong, naming the option.
  std::string check() const;
};

enum class CameraVerdict { kUnchanged, kMoved, kNotSeen, kNew };
/// "unchanged", "moved", "not seen", "new".
const char* cameraVerdictName(CameraVerdict verdict);

struct CameraCheck {
  std::string label;
  CameraVerdict verdict = CameraVerdict::kUnchanged;
  /// Record - new (aligned), in the record's frame [m]; zero unless compared.
  Eigen::Vector3d moved_m = Eigen::Vector3d::Zero();
  double rotated_deg = 0;
  double position_chi2 = 0;  ///< Of moved_m under both registrations' covariances.
  double rotation_chi2 = 0;
  bool used_for_alignment = false;
};

struct FacilityCheck {
  Rigid3d record_from_new;           ///< The new registration's frame in the record's.
  std::vector<CameraCheck> cameras;  ///< The record's cameras, then the new ones.
  int moved = 0, unchanged = 0, not_seen = 0, added = 0;
};

/// Compares `fresh` with `record`. Throws lookboth::Error when fewer than 3
/// cameras are registered in both (no alignment).
FacilityCheck checkFacility(const Registration& fresh, const Registration& record,
                            const FacilityCheckOptions& options = {});

/// The record updated by a later drive, in the record's frame: the cameras
/// `check` found moved, and the new ones, take the fresh registration's pose
/// and covariance (mapped by check.record_from_new); the others keep the
/// record's. Each replaced camera gets a note saying so and by how much.
Registration updateRegistration(const Registration& record, const Registration& fresh,
                                const FacilityCheck& check);

}  // namespace lookboth
