// The registration as a 3-D scene for MRPT's SceneViewer3D (scene.3Dscene in
// the registration output).
#pragma once
#include <filesystem>

#include "lookboth/registration/registration.h"

namespace lookboth {

/// The MRPT scene: cameras as frustums and axes with labels (suspect ones in
/// orange) and, with their covariance, as CPose3DPDFGaussian ("<label> pdf"),
/// the metric trajectory, detection rays (the paper's figure 1).
void writeRegistrationScene(const RegistrationRun& run, const std::filesystem::path& file);

}  // namespace lookboth
