// A registered facility brought up to date by a later drive (`lookboth
// register <later drive> --update <record>`; doc/formats.md, "Updating the
// record"). The later drive is registered on its own first (the configured
// stages); `lookboth check`'s comparison (registration/facility_check.h)
// says which cameras moved; then the joint adjustment runs again in the
// record's frame with the unchanged cameras held at the record by priors
// (their recorded covariance as the weight), so that the moved and new
// cameras are registered against the facility as recorded, and the unchanged
// ones gain this drive's evidence. The cameras this drive did not see keep
// the record's pose.
#pragma once

#include "lookboth/calib/problem.h"
#include "lookboth/registration/facility_check.h"

namespace lookboth {

/// Every pose the problem holds (the input trajectory, the associations'
/// poses, the corrected trajectory, the result's cameras and their
/// covariances) mapped into another world frame by `new_from_world` (metric:
/// the input's unscaled positions are mapped through the problem's scale).
void reexpressProblem(RegistrationProblem& problem, const Rigid3d& new_from_world);

/// Prepares a problem whose stages have run for the joint adjustment again:
/// re-expressed in the record's frame (check.record_from_new), the cameras
/// `check` found unchanged held at the record's poses by priors (a camera the
/// record has no covariance for is not held), the earlier joint's messages
/// removed (the next run says them again). Returns how many cameras are held;
/// throws lookboth::Error when none is (nothing fixes the frame).
int holdAtRecord(RegistrationProblem& problem, const Registration& record,
                 const FacilityCheck& check);

/// What `register --update` writes: `updated` (the joint's result in the
/// record's frame) in the record's frame description, with the record's
/// cameras this drive did not see (or could not register) kept as recorded,
/// and a note per camera and one for the whole saying what changed.
Registration mergeIntoRecord(const Registration& record, const Registration& updated,
                             const FacilityCheck& check);

}  // namespace lookboth
