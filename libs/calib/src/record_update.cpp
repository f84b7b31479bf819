// A registered facility brought up to date by a later drive (record_update.h).
#include "lookboth/calib/record_update.h"

#include <algorithm>

#include "lookboth/core/error.h"
#include "lookboth/core/text.h"
#include "lookboth/registration/site_frame.h"

namespace lookboth {
namespace {

bool fromStage(const std::string& message, const std::string& stage) {
  return message.rfind(stage + ":", 0) == 0 || message.rfind(stage + " ", 0) == 0;
}

void dropStageMessages(std::vector<std::string>& messages, const std::string& stage) {
  messages.erase(std::remove_if(messages.begin(), messages.end(),
                                [&](const std::string& m) { return fromStage(m, stage); }),
                 messages.end());
}

// The messages an earlier run of `stage` left: the run again says them anew.
void forgetStageMessages(Registration& registration, const std::string& stage) {
  dropStageMessages(registration.warnings, stage);
  dropStageMessages(registration.notes, stage);
  for (CameraRegistration& c : registration.cameras) {
    dropStageMessages(c.warnings, stage);
    dropStageMessages(c.notes, stage);
  }
  // Its sentences in the observability statement come after the earlier stages'.
  std::string& message = registration.observability.message;
  const std::string head = stage + ": ";
  std::size_t at = message.rfind(head, 0) == 0 ? 0 : message.find(". " + head);
  if (at != std::string::npos) message.erase(at == 0 ? 0 : at + 1);
  while (!message.empty() && message.back() == ' ') message.pop_back();
}

// An unscaled pose of the input (positions in trajectory units) mapped by a metric transform.
Rigid3d mapUnscaled(const Rigid3d& new_from_world, const Rigid3d& pose, double scale) {
  return Rigid3d(new_from_world.rotation * pose.rotation,
                 new_from_world.rotation * pose.translation + new_from_world.translation / scale);
}

const CameraCheck* findCheck(const FacilityCheck& check, const std::string& label) {
  for (const CameraCheck& c : check.cameras) {
    if (c.label == label) return &c;
  }
  return nullptr;
}

std::string describeChange(const CameraCheck& c) {
  return formatFixed(c.moved_m.norm() * 1000, 1) + " mm and " + formatFixed(c.rotated_deg, 2) +
         " deg";
}

// The note an updated camera gets: what the check found and what was done.
std::string updateNote(const CameraCheck& c, bool held) {
  switch (c.verdict) {
    case CameraVerdict::kMoved:
      return "update: moved " + describeChange(c) +
             " since the record; registered again, against the cameras held at the record";
    case CameraVerdict::kNew:
      return "update: a new camera, registered against the cameras held at the record";
    case CameraVerdict::kNotSeen:
      return "update: registered only by the update's adjustment (this drive's own "
             "registration had not): not compared with the record; check it";
    default:
      return held ? "update: unchanged (" + describeChange(c) +
                        " from the record, within both registrations' uncertainty); held at "
                        "the record by a prior, the pose now rests on the record and this drive"
                  : "update: unchanged (" + describeChange(c) +
                        " from the record); the record has no covariance for it, so it was not "
                        "held: this drive's pose";
  }
}

// A held camera's weight: its recorded covariance, the position block the
// one after a rigid alignment when the record has it. The priors fix the
// frame together, so each should carry the camera's uncertainty against the
// others; the marginal one is mostly the record's gauge (its first pose),
// shared by every camera, and held as independent it lets this drive's
// errors pull the record's shape. The record has no such covariance for the
// rotation: its block stays the marginal one, which holds rotations looser.
Matrix6d priorCovariance(const CameraRegistration& recorded) {
  Matrix6d covariance = *recorded.covariance;
  if (recorded.aligned_position_covariance) {
    covariance.topLeftCorner<3, 3>() = *recorded.aligned_position_covariance;
    covariance.topRightCorner<3, 3>().setZero();
    covariance.bottomLeftCorner<3, 3>().setZero();
  }
  return covariance;
}

}  // namespace

void reexpressProblem(RegistrationProblem& problem, const Rigid3d& new_from_world) {
  const double scale = problem.scale;
  std::vector<StampedPose> samples = problem.input.trajectory.samples();
  for (StampedPose& p : samples) {
    p.world_from_body = mapUnscaled(new_from_world, p.world_from_body, scale);
  }
  problem.input.trajectory = Trajectory(std::move(samples));
  for (Association& a : problem.associations) {
    a.world_from_fisheye = mapUnscaled(new_from_world, a.world_from_fisheye, scale);
  }
  if (problem.metric_trajectory) {
    for (StampedPose& p : *problem.metric_trajectory) {
      p.world_from_body = new_from_world * p.world_from_body;
    }
  }
  problem.result = reexpressRegistration(problem.result, new_from_world, std::nullopt,
                                         problem.result.world_frame);
}

int holdAtRecord(RegistrationProblem& problem, const Registration& record,
                 const FacilityCheck& check) {
  reexpressProblem(problem, check.record_from_new);
  problem.camera_priors.clear();
  for (const CameraCheck& c : check.cameras) {
    if (c.verdict != CameraVerdict::kUnchanged) continue;
    const CameraRegistration* recorded = record.findCamera(c.label);
    if (recorded == nullptr || !recorded->covariance) continue;
    problem.camera_priors[c.label] = {recorded->world_from_camera, priorCovariance(*recorded)};
  }
  if (problem.camera_priors.empty()) {
    throw Error("update: no camera of " + record.dataset +
                " is both unchanged and recorded with a covariance: nothing holds the record's "
                "frame (register the drive on its own and compare it with `lookboth check`)");
  }
  forgetStageMessages(problem.result, "joint");
  return static_cast<int>(problem.camera_priors.size());
}

Registration mergeIntoRecord(const Registration& record, const Registration& updated,
                             const FacilityCheck& check) {
  Registration out = updated;
  out.world_frame = record.world_frame;
  int moved = 0, added = 0, held = 0, kept = 0;
  for (CameraRegistration& camera : out.cameras) {
    const CameraCheck* c = findCheck(check, camera.label);
    if (c == nullptr || camera.status == CameraStatus::kUnregistered) continue;
    const CameraRegistration* recorded = record.findCamera(c->label);
    const bool has_prior = recorded != nullptr && recorded->covariance.has_value();
    camera.notes.push_back(updateNote(*c, has_prior));
    moved += c->verdict == CameraVerdict::kMoved;
    added += c->verdict == CameraVerdict::kNew;
    held += c->verdict == CameraVerdict::kUnchanged && has_prior;
  }
  // The record's cameras this drive did not see or could not register: as recorded.
  for (const CameraRegistration& recorded : record.cameras) {
    auto found =
        std::find_if(out.cameras.begin(), out.cameras.end(),
                     [&](const CameraRegistration& c) { return c.label == recorded.label; });
    if (found != out.cameras.end() && found->status != CameraStatus::kUnregistered) continue;
    CameraRegistration camera = recorded;
    camera.notes.push_back("update: not registered by this drive; kept from the record");
    if (found == out.cameras.end()) {
      out.cameras.push_back(camera);
    } else {
      *found = camera;
    }
    ++kept;
  }
  std::sort(
      out.cameras.begin(), out.cameras.end(),
      [](const CameraRegistration& a, const CameraRegistration& b) { return a.label < b.label; });
  out.notes.push_back("update of the record of " + record.dataset + " (" + record.created +
                      "): " + std::to_string(moved) + " moved and " + std::to_string(added) +
                      " new cameras registered against " + std::to_string(held) +
                      " unchanged ones held at the record; " + std::to_string(kept) +
                      " kept from the record as they were");
  return out;
}

}  // namespace lookboth
