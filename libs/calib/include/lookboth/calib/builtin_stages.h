// The paper's estimation stages (sections VI-VII of look-both-ways.tex), each
// an options struct (read from its section of the configuration, units in
// comments, check()) and a function on the shared RegistrationProblem. They
// are registered by name in StageRegistry::global():
//   associate           robot pose at each detection (linear + slerp, no extrapolation)
//   motion_calibration  scale s and fisheye_from_marker from relative motions (eq. 1-2)
//   look_down           world_from_camera per camera from its detections (eq. 3)
//   look_up             camera positions refined by fisheye reprojection of blobs (eq. 4-5)
//   joint               beyond the paper: one adjustment of trajectory, scale,
//                       fisheye_from_marker, cameras and clock offsets (joint.h)
#pragma once
#include "lookboth/calib/associate.h"
#include "lookboth/calib/joint.h"
#include "lookboth/calib/look_down.h"
#include "lookboth/calib/look_up.h"
#include "lookboth/calib/motion_calibration.h"
#include "lookboth/calib/stage_registry.h"

namespace lookboth {

/// Adds associate, motion_calibration, look_down, look_up, joint to a registry.
void registerPaperStages(StageRegistry& registry);

}  // namespace lookboth
