// Re-checking a registered facility (facility_check.h).
#include "lookboth/registration/facility_check.h"

#include <Eigen/LU>
#include <cmath>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/geometry/lie.h"
#include "lookboth/geometry/umeyama.h"
#include "lookboth/registration/site_frame.h"

namespace lookboth {

const char* cameraVerdictName(CameraVerdict verdict) {
  switch (verdict) {
    case CameraVerdict::kUnchanged:
      return "unchanged";
    case CameraVerdict::kMoved:
      return "moved";
    case CameraVerdict::kNotSeen:
      return "not seen";
    case CameraVerdict::kNew:
      return "new";
  }
  return "?";
}

std::string FacilityCheckOptions::check() const {
  if (!(max_chi2 > 0)) return "max_chi2: must be positive";
  if (!(min_position_m >= 0)) return "min_position_m: must not be negative";
  if (!(min_rotation_deg >= 0)) return "min_rotation_deg: must not be negative";
  return "";
}

namespace {

constexpr double kDeg = M_PI / 180;

/// A camera registered in both.
struct Common {
  const CameraRegistration* record;
  const CameraRegistration* fresh;
};

bool registered(const CameraRegistration* c) {
  return c != nullptr && c->status != CameraStatus::kUnregistered;
}

/// Its position's covariance once a rigid alignment is projected out when
/// joint computed it (what two registrations' difference after an alignment
/// shows), else the full one; 1 cm when neither.
Eigen::Matrix3d positionCovariance(const CameraRegistration& c) {
  if (c.aligned_position_covariance) return *c.aligned_position_covariance;
  if (c.covariance) return c.covariance->topLeftCorner<3, 3>();
  return Eigen::Matrix3d::Identity() * 1e-4;
}

Eigen::Matrix3d rotationCovariance(const CameraRegistration& c) {
  if (c.covariance) return c.covariance->bottomRightCorner<3, 3>();
  return Eigen::Matrix3d::Identity() * kDeg * kDeg;
}

Rigid3d alignCommon(const std::vector<Common>& common, const std::vector<bool>& used) {
  std::vector<Eigen::Vector3d> src, dst;
  std::vector<double> weights;
  for (std::size_t i = 0; i < common.size(); ++i) {
    if (!used[i]) continue;
    src.push_back(common[i].fresh->world_from_camera.translation);
    dst.push_back(common[i].record->world_from_camera.translation);
    weights.push_back(3.0 / (positionCovariance(*common[i].record).trace() +
                             positionCovariance(*common[i].fresh).trace()));
  }
  std::string why;
  const auto aligned = alignRigid3(src, dst, weights, &why);
  if (!aligned) throw Error("check: the cameras in both registrations give no alignment: " + why);
  return Rigid3d(aligned->dst_from_src.rotation, aligned->dst_from_src.translation);
}

CameraCheck compare(const Common& c, const Rigid3d& record_from_new,
                    const FacilityCheckOptions& options) {
  CameraCheck check;
  check.label = c.record->label;
  const Rigid3d fresh = record_from_new * c.fresh->world_from_camera;
  const Eigen::Matrix3d turn = record_from_new.rotation.toRotationMatrix();
  check.moved_m = c.record->world_from_camera.translation - fresh.translation;
  const Eigen::Matrix3d position =
      positionCovariance(*c.record) + turn * positionCovariance(*c.fresh) * turn.transpose();
  check.position_chi2 = check.moved_m.dot(position.inverse() * check.moved_m);
  // Both rotations' right perturbations are in the camera's own frame.
  const Eigen::Vector3d turned =
      so3Log(c.record->world_from_camera.rotation.conjugate() * fresh.rotation);
  check.rotated_deg = turned.norm() / kDeg;
  const Eigen::Matrix3d rotation = rotationCovariance(*c.record) + rotationCovariance(*c.fresh);
  check.rotation_chi2 = turned.dot(rotation.inverse() * turned);
  const bool moved_position =
      check.position_chi2 > options.max_chi2 && check.moved_m.norm() > options.min_position_m;
  const bool turned_too_much =
      check.rotation_chi2 > options.max_chi2 && check.rotated_deg > options.min_rotation_deg;
  check.verdict =
      moved_position || turned_too_much ? CameraVerdict::kMoved : CameraVerdict::kUnchanged;
  return check;
}

/// The alignment over the cameras that agree: the most significant moved
/// camera is left out, one at a time, while at least 3 remain.
Rigid3d robustAlignment(const std::vector<Common>& common, const FacilityCheckOptions& options,
                        std::vector<bool>* used) {
  used->assign(common.size(), true);
  std::size_t in_use = common.size();
  while (true) {
    const Rigid3d aligned = alignCommon(common, *used);
    double worst = 0;
    std::size_t worst_index = common.size();
    for (std::size_t i = 0; i < common.size(); ++i) {
      if (!(*used)[i]) continue;
      const CameraCheck check = compare(common[i], aligned, options);
      const double chi2 = std::max(check.position_chi2, check.rotation_chi2);
      if (check.verdict == CameraVerdict::kMoved && chi2 > worst) {
        worst = chi2;
        worst_index = i;
      }
    }
    if (worst_index == common.size() || in_use <= 3) return aligned;
    (*used)[worst_index] = false;
    --in_use;
  }
}

}  // namespace

FacilityCheck checkFacility(const Registration& fresh, const Registration& record,
                            const FacilityCheckOptions& options) {
  if (const std::string why = options.check(); !why.empty()) throw Error("check: " + why);
  std::vector<Common> common;
  FacilityCheck result;
  for (const CameraRegistration& r : record.cameras) {
    if (!registered(&r)) continue;
    const CameraRegistration* f = fresh.findCamera(r.label);
    if (registered(f)) {
      common.push_back({&r, f});
    }
  }
  if (common.size() < 3) {
    throw Error("check: " + std::to_string(common.size()) +
                " cameras are registered in both registrations; the comparison needs 3");
  }
  std::vector<bool> used;
  result.record_from_new = robustAlignment(common, options, &used);
  std::size_t next = 0;
  for (const CameraRegistration& r : record.cameras) {
    if (!registered(&r)) continue;
    if (next < common.size() && common[next].record == &r) {
      CameraCheck check = compare(common[next], result.record_from_new, options);
      check.used_for_alignment = used[next++];
      (check.verdict == CameraVerdict::kMoved ? result.moved : result.unchanged)++;
      result.cameras.push_back(check);
    } else {
      result.cameras.push_back({r.label, CameraVerdict::kNotSeen});
      ++result.not_seen;
    }
  }
  for (const CameraRegistration& f : fresh.cameras) {
    if (registered(&f) && !registered(record.findCamera(f.label))) {
      result.cameras.push_back({f.label, CameraVerdict::kNew});
      ++result.added;
    }
  }
  return result;
}

Registration updateRegistration(const Registration& record, const Registration& fresh,
                                const FacilityCheck& check) {
  // The fresh registration in the record's frame; its frame description is the record's.
  const Registration mapped =
      reexpressRegistration(fresh, check.record_from_new, std::nullopt, record.world_frame);
  Registration updated = record;
  for (const CameraCheck& c : check.cameras) {
    if (c.verdict != CameraVerdict::kMoved && c.verdict != CameraVerdict::kNew) continue;
    const CameraRegistration* replacement = mapped.findCamera(c.label);
    if (replacement == nullptr) continue;
    CameraRegistration camera = *replacement;
    camera.notes.push_back(c.verdict == CameraVerdict::kNew
                               ? "update: a new camera, registered from " + fresh.dataset
                               : "update: moved " + formatFixed(c.moved_m.norm() * 1000, 1) +
                                     " mm and turned " + formatFixed(c.rotated_deg, 2) +
                                     " deg since the record; re-registered from " + fresh.dataset);
    bool replaced = false;
    for (CameraRegistration& old : updated.cameras) {
      if (old.label == camera.label) {
        old = camera;
        replaced = true;
      }
    }
    if (!replaced) updated.cameras.push_back(camera);
  }
  updated.notes.push_back("update: " + std::to_string(check.moved) + " moved and " +
                          std::to_string(check.added) + " new cameras taken from " + fresh.dataset +
                          "; " + std::to_string(check.unchanged) + " unchanged and " +
                          std::to_string(check.not_seen) + " not seen kept from the record");
  return updated;
}

}  // namespace lookboth
